!> Run outputs: trace.csv (flushed row by row), summary.json, output folders.
module trace_output
    use iso_c_binding, only: c_int, c_char, c_null_char
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_INTERNAL, raise
    implicit none
    private

    character(len=*), parameter, public :: TRACE_HEADER = &
        't,u_n,v_n,p_n,e_kin,e_el,e_contact,e_total,newton_its,active'  !! trace.csv header

    interface
        !> int mkdir(const char *path, mode_t mode) from the C library.
        function c_mkdir(path, mode) bind(C, name='mkdir') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)
            integer(c_int), value :: mode
            integer(c_int) :: r
        end function c_mkdir
    end interface

    public :: make_dirs, trace_open, trace_row, json_real, json_string

contains

    !> Create a folder and its parents (like mkdir -p); existing folders are fine.
    subroutine make_dirs(path, stat, errmsg)
        character(len=*), intent(in) :: path                !! folder
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: i, r, n
        logical :: exists
        stat = STAT_OK
        n = len_trim(path)
        do i = 2, n + 1
            if (i <= n) then
                if (path(i:i) /= '/') cycle
            end if
            r = c_mkdir(path(1:i - 1)//c_null_char, int(o'755', c_int))
        end do
        inquire (file=trim(path)//'/.', exist=exists)
        if (.not. exists) call raise(stat, errmsg, STAT_INTERNAL, trim(path)//': cannot create folder')
        if (r < 0) continue
    end subroutine make_dirs

    !> Open (replace) a trace file and write its header.
    subroutine trace_open(path, unit, stat, errmsg)
        character(len=*), intent(in) :: path                !! trace.csv path
        integer, intent(out) :: unit                        !! open unit
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: ios
        stat = STAT_OK
        open (newunit=unit, file=path, status='replace', action='write', iostat=ios)
        if (ios /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, trim(path)//': cannot write')
            return
        end if
        write (unit, '(a)') TRACE_HEADER
        flush (unit)
    end subroutine trace_open

    !> Write and flush one trace row.
    subroutine trace_row(unit, t, un, vn, pn, e_kin, e_el, e_contact, e_total, newton_its, active)
        integer, intent(in) :: unit          !! trace unit
        real(dp), intent(in) :: t            !! time
        real(dp), intent(in) :: un           !! normal displacement at the probe
        real(dp), intent(in) :: vn           !! normal velocity at the probe
        real(dp), intent(in) :: pn           !! contact pressure at the probe
        real(dp), intent(in) :: e_kin        !! kinetic energy
        real(dp), intent(in) :: e_el         !! elastic energy
        real(dp), intent(in) :: e_contact    !! Nitsche contact energy
        real(dp), intent(in) :: e_total      !! e_kin + e_el
        integer, intent(in) :: newton_its    !! Newton iterations of the step
        integer, intent(in) :: active        !! active contact quadrature points
        write (unit, '(8(es24.16e3, ","), i0, ",", i0)') t, un, vn, pn, e_kin, e_el, &
            e_contact, e_total, newton_its, active
        flush (unit)
    end subroutine trace_row

    !> A real as a JSON number (non-finite values as null).
    function json_real(x) result(s)
        real(dp), intent(in) :: x    !! value
        character(len=:), allocatable :: s
        character(len=40) :: buf
        if (x /= x .or. abs(x) > huge(x)) then
            s = 'null'
        else
            write (buf, '(es24.16e3)') x
            s = trim(adjustl(buf))
        end if
    end function json_real

    !> A string as a JSON string (quotes and backslashes escaped).
    function json_string(x) result(s)
        character(len=*), intent(in) :: x    !! value
        character(len=:), allocatable :: s
        integer :: i
        s = '"'
        do i = 1, len_trim(x)
            select case (x(i:i))
            case ('"', '\')
                s = s//'\'//x(i:i)
            case default
                if (iachar(x(i:i)) < 32) then
                    s = s//' '
                else
                    s = s//x(i:i)
                end if
            end select
        end do
        s = s//'"'
    end function json_string
end module trace_output
