!> Run outputs: trace.csv (buffered, written in whole rows), JSON helpers, output folders.
module trace_output
    use iso_c_binding, only: c_int, c_char, c_null_char, c_double
    use ieee_arithmetic, only: ieee_is_finite, ieee_is_nan
    use text, only: text_json_string => json_string
    use kinds, only: dp, i8
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_INTERNAL, raise
    use os_files, only: fd_open, fd_write, fd_close, fd_reopen, fd_sync, sys_error, write_status
    implicit none
    private

    character(len=*), parameter, public :: TRACE_HEADER = &
        't,u_n,v_n,p_n,e_kin,e_el,e_contact,e_total,newton_its,active,e_load,f_n'  !! trace.csv header
    integer, parameter :: TRACE_BUFFER = 65536   !! bytes of rows kept before a write
    integer, parameter, public :: TRACE_ROW_BYTES = 257 !! typical row length (10 reals, 2 small integers)
    integer, parameter :: ROW_MAX = 352          !! longest row (10 x 24 + separators + 2 integers)

    !> A trace file being written: rows are buffered and written whole.
    type, public :: trace_t
        integer :: fd = -1                         !! descriptor, -1 = closed
        character(len=:), allocatable :: path      !! file name (for messages)
        character(len=:), allocatable :: buf       !! rows not yet written
        integer :: n = 0                           !! bytes used in buf
        integer(i8) :: bytes = 0                   !! bytes written to the file
    end type trace_t

    interface
        !> int mkdir(const char *path, mode_t mode) from the C library.
        !> Create one folder (mode 0755 before the umask): 0 when made or when that name
        !> is there already (a folder or not), else errno (run_guard.c).
        function c_mkdir(path) bind(C, name='dc_mkdir') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated path
            integer(c_int) :: r
        end function c_mkdir
        !> es24.16e3 formatting in C (run_guard.c); 0 when the value is left to Fortran.
        function c_format_es(x, out) bind(C, name='dc_format_es') result(r)
            import :: c_int, c_char, c_double
            real(c_double), value :: x                      !! value
            character(kind=c_char), intent(out) :: out(24)  !! its text
            integer(c_int) :: r
        end function c_format_es
    end interface

    public :: make_dirs, trace_open, trace_reopen, trace_row, trace_flush, trace_sync, &
              trace_close, trace_size, json_real, json_string

contains

    !> Create a folder and its parents (like mkdir -p); existing folders are fine. On
    !> failure one line: `said` (how the caller names the folder; default: its path), then
    !> why: a file in the way, or the system's text for the first folder of the path that
    !> could not be made. The status is write_status's: STAT_INTERNAL (exit 4) when the
    !> file system has no room or is read-only, STAT_BAD_INPUT (exit 2) for a bad path.
    subroutine make_dirs(path, stat, errmsg, said)
        character(len=*), intent(in) :: path                !! folder
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=*), intent(in), optional :: said      !! the folder as messages name it
        character(len=:), allocatable :: name
        integer :: i, r, n, err
        logical :: exists, is_folder
        stat = STAT_OK
        r = 0
        err = 0     ! the errno of the first folder not made where nothing is in the way
        n = len_trim(path)
        do i = 2, n + 1
            if (i <= n) then
                if (path(i:i) /= '/') cycle
            end if
            r = c_mkdir(path(1:i - 1)//c_null_char)
            if (r /= 0 .and. err == 0) then
                inquire (file=path(1:i - 1), exist=exists)
                if (.not. exists) err = r
            end if
        end do
        inquire (file=trim(path)//'/.', exist=is_folder)
        if (is_folder) return
        name = trim(path)
        if (present(said)) name = said
        inquire (file=trim(path), exist=exists)
        if (exists) then
            call raise(stat, errmsg, STAT_BAD_INPUT, name//': cannot create the folder '// &
                       '(a file of that name is in the way)')
        else
            if (err == 0) err = r
            call raise(stat, errmsg, write_status(err), name//': cannot create the folder ('// &
                       sys_error(err)//')')
        end if
    end subroutine make_dirs

    !> Open (create or truncate) a trace file and buffer its header; rows are kept in
    !> memory and written whole (trace_flush), so the file only ever holds complete rows.
    subroutine trace_open(path, tr, stat, errmsg)
        character(len=*), intent(in) :: path                !! file to write
        type(trace_t), intent(out) :: tr                    !! the trace
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        call fd_open(path, tr%fd, stat, errmsg)
        if (stat /= STAT_OK) return
        tr%path = trim(path)
        allocate (character(len=TRACE_BUFFER) :: tr%buf)
        tr%buf(1:len(TRACE_HEADER) + 1) = TRACE_HEADER//new_line('a')
        tr%n = len(TRACE_HEADER) + 1
    end subroutine trace_open

    !> Continue an existing trace file: its first `bytes` bytes are kept (the rows up to
    !> a checkpoint), the rest is cut off, and new rows are appended after them.
    subroutine trace_reopen(path, bytes, tr, stat, errmsg)
        character(len=*), intent(in) :: path                !! file to continue
        integer(i8), intent(in) :: bytes                    !! bytes to keep
        type(trace_t), intent(out) :: tr                    !! the trace
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        call fd_reopen(path, bytes, tr%fd, stat, errmsg)
        if (stat /= STAT_OK) return
        tr%path = trim(path)
        allocate (character(len=TRACE_BUFFER) :: tr%buf)
        tr%n = 0
        tr%bytes = bytes
    end subroutine trace_reopen

    !> Write the buffered rows and flush the file to the device (before a checkpoint).
    subroutine trace_sync(tr, stat, errmsg)
        type(trace_t), intent(inout) :: tr                  !! the trace
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        call trace_flush(tr, stat, errmsg)
        if (stat == STAT_OK .and. tr%fd >= 0) call fd_sync(tr%fd, tr%path, stat, errmsg)
    end subroutine trace_sync

    !> Append one row (written when the buffer is full or at trace_flush).
    subroutine trace_row(tr, t, un, vn, pn, e_kin, e_el, e_contact, e_total, newton_its, &
                         active, e_load, f_n, stat, errmsg)
        type(trace_t), intent(inout) :: tr   !! the trace
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
        real(dp), intent(in) :: e_load       !! potential of the load, -u . L
        real(dp), intent(in) :: f_n          !! total normal contact force (<= 0, as p_n)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=ROW_MAX) :: row
        integer :: n
        stat = STAT_OK
        ! Same text as write (row, '(8(es24.16e3, ","), i0, ",", i0, 2(",", es24.16e3))'),
        ! without libgfortran's formatted I/O (most of the cost of a row).
        n = 0
        call put_real(t); call put_real(un); call put_real(vn); call put_real(pn)
        call put_real(e_kin); call put_real(e_el); call put_real(e_contact); call put_real(e_total)
        call put_int(newton_its); call put_int(active)
        call put_real(e_load); call put_real(f_n)
        row(n:n) = ' '
        n = n - 1    ! without the last comma
        if (tr%n + n + 1 > len(tr%buf)) then
            call trace_flush(tr, stat, errmsg)
            if (stat /= STAT_OK) return
        end if
        tr%buf(tr%n + 1:tr%n + n) = row(1:n)
        tr%buf(tr%n + n + 1:tr%n + n + 1) = new_line('a')
        tr%n = tr%n + n + 1

    contains

        !> Append x as es24.16e3 and a comma; a value that is not finite (the last row of a
        !> run stopped as unstable) as nan, inf or -inf without blanks, as Python and numpy
        !> write them: pandas reads those as numbers, but gfortran's right-aligned NaN
        !> and Infinity, with their leading blanks, as text, and with them the whole
        !> column (e_total, ...) of the trace.
        subroutine put_real(x)
            real(dp), intent(in) :: x   !! value
            character(len=:), allocatable :: word
            if (.not. ieee_is_finite(x)) then
                if (ieee_is_nan(x)) then
                    word = 'nan'
                else
                    word = merge('inf ', '-inf', x > 0.0_dp)
                    word = trim(word)
                end if
                row(n + 1:n + len(word) + 1) = word//','
                n = n + len(word) + 1
                return
            end if
            if (c_format_es(x, row(n + 1:n + 24)) == 0) write (row(n + 1:n + 24), '(es24.16e3)') x
            row(n + 25:n + 25) = ','
            n = n + 25
        end subroutine put_real

        !> Append k as i0 and a comma.
        subroutine put_int(k)
            integer, intent(in) :: k   !! value
            character(len=12) :: d
            integer :: m, j
            m = abs(k)
            j = len(d)
            do
                d(j:j) = achar(iachar('0') + mod(m, 10))
                m = m / 10
                if (m == 0) exit
                j = j - 1
            end do
            if (k < 0) then
                j = j - 1
                d(j:j) = '-'
            end if
            row(n + 1:n + len(d) - j + 1) = d(j:)
            n = n + len(d) - j + 2
            row(n:n) = ','
        end subroutine put_int
    end subroutine trace_row

    !> Write the buffered rows (whole rows, one system call).
    subroutine trace_flush(tr, stat, errmsg)
        type(trace_t), intent(inout) :: tr                  !! the trace
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        stat = STAT_OK
        if (tr%fd < 0 .or. tr%n == 0) return
        call fd_write(tr%fd, tr%buf(1:tr%n), tr%path, stat, errmsg)
        if (stat == STAT_OK) tr%bytes = tr%bytes + tr%n
        tr%n = 0
    end subroutine trace_flush

    !> The trace's length in bytes with the rows still buffered: the file's size once
    !> they are written (trace_flush).
    pure integer(i8) function trace_size(tr)
        type(trace_t), intent(in) :: tr      !! the trace
        trace_size = tr%bytes + int(tr%n, i8)
    end function trace_size

    !> Flush and close the trace (every error reported).
    subroutine trace_close(tr, stat, errmsg)
        type(trace_t), intent(inout) :: tr                  !! the trace
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: st2
        stat = STAT_OK
        if (tr%fd < 0) return
        call trace_flush(tr, stat, errmsg)
        if (stat == STAT_OK) then
            call fd_close(tr%fd, tr%path, stat, errmsg)
        else
            call fd_close(tr%fd, tr%path, st2)
        end if
        tr%fd = -1
    end subroutine trace_close

    !> A real as a JSON number (non-finite values as null).
    pure function json_real(x) result(s)
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

    !> A string (trailing blanks dropped) as a JSON string in summary.json's form:
    !> text's json_string with control characters as blanks.
    pure function json_string(x) result(s)
        character(len=*), intent(in) :: x    !! value
        character(len=:), allocatable :: s
        s = text_json_string(trim(x), blank_controls=.true.)
    end function json_string
end module trace_output
