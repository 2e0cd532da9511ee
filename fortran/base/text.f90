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

    public :: int_text, real_text, fixed_text, utf8_len, lower, env_text, json_string, counted

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
    pure function real_text(x, digits) result(s)
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

    !> A real in fixed-point form with `decimals` decimals and at least one digit before
    !> the point ('0.850', '-0.5'; the f0.d edit descriptor writes '.850').
    pure function fixed_text(x, decimals) result(s)
        real(dp), intent(in) :: x          !! value
        integer, intent(in) :: decimals    !! digits after the point
        character(len=:), allocatable :: s
        character(len=64) :: buf, fmt
        write (fmt, '(a, i0, a)') '(f0.', decimals, ')'
        write (buf, fmt) x
        s = trim(adjustl(buf))
        if (s(1:1) == '.') then
            s = '0'//s
        else if (len(s) >= 2) then
            if (s(1:2) == '-.') s = '-0'//s(2:)
        end if
    end function fixed_text

    !> Length (1 to 4) of the well-formed UTF-8 sequence that starts at s(i:i), 0 if none
    !> does (the Unicode standard's table 3-7: no overlong forms, no surrogates, at most
    !> U+10FFFF). JSON and the summary files are UTF-8: other bytes must be escaped.
    pure integer function utf8_len(s, i) result(n)
        character(len=*), intent(in) :: s   !! text
        integer, intent(in) :: i            !! position of the first byte
        integer :: k, b, lo, hi
        lo = 128; hi = 191
        select case (iachar(s(i:i)))
        case (0:127); n = 1
        case (194:223); n = 2
        case (224); n = 3; lo = 160
        case (225:236, 238:239); n = 3
        case (237); n = 3; hi = 159
        case (240); n = 4; lo = 144
        case (241:243); n = 4
        case (244); n = 4; hi = 143
        case default; n = 0
        end select
        do k = 1, n - 1
            if (i + k > len(s)) then
                n = 0; return
            end if
            b = iachar(s(i + k:i + k))
            if (b < lo .or. b > hi) then
                n = 0; return
            end if
            lo = 128; hi = 191
        end do
    end function utf8_len

    !> JSON string literal of s: " and \ escaped, UTF-8 as it is, a byte that is not
    !> UTF-8 (e.g. of a path given on the command line) as \udcXX, the lone surrogate by
    !> which Python decodes such a byte of a file name, so that the text stays UTF-8 and
    !> the name round-trips. Control characters (and DEL) are escaped as \u00XX, or with
    !> blank_controls written as blanks (DEL kept), the form of summary.json's messages.
    pure function json_string(s, blank_controls) result(js)
        character(len=*), intent(in) :: s              !! text (trailing blanks kept)
        logical, intent(in), optional :: blank_controls !! controls as blanks (default: escaped)
        character(len=:), allocatable :: js
        character(len=6) :: u
        logical :: blank
        integer :: i, n, c
        blank = .false.
        if (present(blank_controls)) blank = blank_controls
        js = '"'
        i = 1
        do while (i <= len(s))
            n = utf8_len(s, i)
            c = iachar(s(i:i))
            if (s(i:i) == '"' .or. s(i:i) == '\') then
                js = js//'\'//s(i:i)
            else if (c < 32 .and. blank) then
                js = js//' '
            else if ((c < 32 .or. c == 127) .and. .not. blank) then
                write (u, '(a, z4.4)') '\u', c
                js = js//u
            else if (n == 0) then
                write (u, '(a, z2.2)') '\udc', c
                js = js//u
            else
                js = js//s(i:i + n - 1)
            end if
            i = i + max(n, 1)
        end do
        js = js//'"'
    end function json_string

    !> `s` in lower case (ASCII letters; other bytes as they are).
    pure function lower(s) result(r)
        character(len=*), intent(in) :: s   !! text
        character(len=len(s)) :: r
        integer :: i
        r = s
        do i = 1, len(s)
            if (s(i:i) >= 'A' .and. s(i:i) <= 'Z') r(i:i) = achar(iachar(s(i:i)) + 32)
        end do
    end function lower
    !> The value of an environment variable, blanks trimmed on both sides ('' when it is
    !> not set or longer than 64 characters): the DYNCONTACT_* switches read at set-up.
    function env_text(name) result(v)
        character(len=*), intent(in) :: name    !! variable
        character(len=:), allocatable :: v
        character(len=64) :: buf
        integer :: length, st
        call get_environment_variable(name, buf, length, st)
        if (st /= 0 .or. length == 0) then
            v = ''
        else
            v = trim(adjustl(buf))
        end if
    end function env_text


    !> "n noun" with the noun in the plural unless n = 1 ('1 contact facet', '2 steps').
    pure function counted(n, noun) result(s)
        integer(i8), intent(in) :: n            !! the count
        character(len=*), intent(in) :: noun    !! the noun, singular
        character(len=:), allocatable :: s
        s = int_text(n)//' '//noun
        if (n /= 1_i8) s = s//'s'
    end function counted
end module text
