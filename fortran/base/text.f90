!> Numbers as text for messages and JSON, in one place: integers in i0 form, reals in
!> ES form with a 3-digit exponent (never the E-less "2.225-307" of a plain es edit
!> descriptor), either with a given number of significant digits or with the fewest
!> that read back to the same double.
module text
    use kinds, only: dp, i8
    implicit none
    private

    !> An integer (default or 64-bit) as text.
    interface int_text
        module procedure int_text_default, int_text_i8
    end interface int_text

    public :: int_text, real_text

contains

    !> A default integer as text.
    pure function int_text_default(i) result(s)
        integer, intent(in) :: i   !! value
        character(len=:), allocatable :: s
        character(len=12) :: buf
        write (buf, '(i0)') i
        s = trim(buf)
    end function int_text_default

    !> A 64-bit integer as text.
    pure function int_text_i8(i) result(s)
        integer(i8), intent(in) :: i   !! value
        character(len=:), allocatable :: s
        character(len=24) :: buf
        write (buf, '(i0)') i
        s = trim(buf)
    end function int_text_i8

    !> A real in ES format with a 3-digit exponent: `digits` significant digits, or (by
    !> default) the fewest that read back to x.
    function real_text(x, digits) result(s)
        real(dp), intent(in) :: x                !! value
        integer, intent(in), optional :: digits  !! significant digits
        character(len=:), allocatable :: s
        character(len=32) :: buf, fmt
        real(dp) :: y
        integer :: p
        do p = 1, 16
            write (fmt, '(a, i0, a)') '(es32.', p, 'e3)'
            write (buf, fmt) x
            read (buf, *) y
            if (present(digits)) then
                if (p + 1 >= digits) exit
            else if (y == x) then
                exit
            end if
        end do
        s = trim(adjustl(buf))
    end function real_text
end module text
