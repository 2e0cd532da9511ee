!> Checked file operations, the output-folder lock and the signal handlers, through the
!> small C layer run_guard.c (POSIX calls with their errno). Every failure comes back
!> as a status and a one-line message naming the path and the system's reason.
module os_files
    use iso_c_binding, only: c_int, c_long, c_long_long, c_char, c_null_char, c_int64_t
    use kinds, only: i8
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_INTERNAL, raise
    implicit none
    private

    character(len=*), parameter, public :: LOCK_NAME = '.dyncontact.lock' !! lock file of an output folder

    interface
        function c_signals_install() bind(C, name='dc_signals_install') result(r)
            import :: c_int
            integer(c_int) :: r
        end function c_signals_install
        !> Point SIGINT or SIGTERM at the stop flag's handler, for a library caller: 0 or
        !> errno (run_guard.c).
        function c_stop_signals_catch(sig) bind(C, name='dc_stop_signals_catch') result(r)
            import :: c_int
            integer(c_int), value :: sig   !! SIGINT or SIGTERM
            integer(c_int) :: r
        end function c_stop_signals_catch
        !> SIGINT / SIGTERM during a gmsh read end the process from this call on (run_guard.c).
        subroutine c_exit_on_read_signal() bind(C, name='dc_exit_on_read_signal')
        end subroutine c_exit_on_read_signal
        !> Name a file or empty folder that a stop during a gmsh read removes: 0 or errno.
        function c_stop_removes(path) bind(C, name='dc_stop_removes') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated path
            integer(c_int) :: r
        end function c_stop_removes
        !> Take back one naming of path by c_stop_removes (gmsh_shim.c).
        subroutine c_stop_keeps(path) bind(C, name='dc_stop_keeps')
            import :: c_char
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated path
        end subroutine c_stop_keeps
        !> Begin the guard around a program's own calls into gmsh (gmsh_shim.c): 1, or 0
        !> when another call holds it.
        function c_gmsh_guard_begin(line_start, line_end) bind(C, name='dc_gmsh_guard_begin') &
            result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: line_start(*)  !! NUL-terminated text
            character(kind=c_char), intent(in) :: line_end(*)    !! NUL-terminated text
            integer(c_int) :: r
        end function c_gmsh_guard_begin
        !> Inside the guard, right after gmsh's initialization (gmsh_shim.c).
        subroutine c_gmsh_guard_after_init() bind(C, name='dc_gmsh_guard_after_init')
        end subroutine c_gmsh_guard_after_init
        !> End the guard the calling thread began (gmsh_shim.c).
        subroutine c_gmsh_guard_end() bind(C, name='dc_gmsh_guard_end')
        end subroutine c_gmsh_guard_end
        !> Open path for writing (created or truncated): fd >= 0 or -errno.
        function c_fd_open(path) bind(C, name='dc_fd_open') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated path
            integer(c_int) :: r
        end function c_fd_open
        !> Write all n bytes of buf; on failure the file is cut back to its last newline.
        function c_fd_write(fd, buf, n) bind(C, name='dc_fd_write') result(r)
            import :: c_int, c_char, c_long
            integer(c_int), value :: fd                   !! descriptor
            character(kind=c_char), intent(in) :: buf(*)  !! bytes
            integer(c_long), value :: n                   !! how many
            integer(c_int) :: r
        end function c_fd_write
        !> Close a descriptor: 0 or errno.
        function c_fd_close(fd) bind(C, name='dc_fd_close') result(r)
            import :: c_int
            integer(c_int), value :: fd  !! descriptor
            integer(c_int) :: r
        end function c_fd_close
        !> Flush a descriptor's data to the device: 0 or errno.
        function c_fsync(fd) bind(C, name='dc_fsync') result(r)
            import :: c_int
            integer(c_int), value :: fd  !! descriptor
            integer(c_int) :: r
        end function c_fsync
        !> Open an existing file for writing, cut back to size, offset at its end: fd or -errno.
        function c_fd_reopen(path, size) bind(C, name='dc_fd_reopen') result(r)
            import :: c_int, c_char, c_long_long
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated path
            integer(c_long_long), value :: size            !! bytes kept
            integer(c_int) :: r
        end function c_fd_reopen
        !> 64-bit FNV-1a hash of n bytes, continuing from h.
        function c_hash64(buf, n, h) bind(C, name='dc_hash64') result(r)
            import :: c_char, c_long_long
            character(kind=c_char), intent(in) :: buf(*)  !! bytes
            integer(c_long_long), value :: n, h  !! how many; hash to continue from (0: start)
            integer(c_long_long) :: r
        end function c_hash64
        !> rename(2): 0 or errno.
        function c_rename(from, to) bind(C, name='dc_rename') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: from(*), to(*)  !! NUL-terminated paths
            integer(c_int) :: r
        end function c_rename
        !> Remove a file (a missing one is no error): 0 or errno.
        function c_unlink(path) bind(C, name='dc_unlink') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated path
            integer(c_int) :: r
        end function c_unlink
        !> 0 if path does not exist or is writable by us, else errno of access(W_OK).
        function c_check_writable(path) bind(C, name='dc_check_writable') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated path
            integer(c_int) :: r
        end function c_check_writable
        !> 1 when errno err says the file system has no room or takes no writes, else 0.
        function c_errno_no_room(err) bind(C, name='dc_errno_no_room') result(r)
            import :: c_int
            integer(c_int), value :: err  !! errno value
            integer(c_int) :: r
        end function c_errno_no_room
        !> Short text of an errno value.
        subroutine c_strerror(err, msg, n) bind(C, name='dc_strerror')
            import :: c_int, c_char
            integer(c_int), value :: err                   !! errno value
            character(kind=c_char), intent(out) :: msg(*)  !! its text, blank-padded
            integer(c_int), value :: n                     !! length of msg
        end subroutine c_strerror
        !> Take the lock file: 0 (taken), -pid (held by the live process pid) or errno.
        function c_lock_take(path) bind(C, name='dc_lock_take') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated lock file path
            integer(c_int) :: r
        end function c_lock_take
        !> The host name of the other machine that wrote a lock file: 1 (host set), or 0.
        function c_lock_host(path, host, n) bind(C, name='dc_lock_host') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)   !! NUL-terminated lock file path
            character(kind=c_char), intent(out) :: host(*)  !! its host name, blank-padded
            integer(c_int), value :: n                      !! length of host
            integer(c_int) :: r
        end function c_lock_host
        !> Bytes and inodes an unprivileged user may still create on path's file system.
        function c_free_space(path, bytes, files) bind(C, name='dc_free_space') result(r)
            import :: c_int, c_char, c_int64_t
            character(kind=c_char), intent(in) :: path(*)    !! NUL-terminated path
            integer(c_int64_t), intent(out) :: bytes, files  !! bytes and inodes left (-1: not told)
            integer(c_int) :: r
        end function c_free_space
        !> Remove the files of dir named prefix*suffix (with after >= 0: prefix N suffix,
        !> N a number > after): 0 or the first errno met.
        function c_remove_matching(dir, prefix, suffix, after) &
            bind(C, name='dc_remove_matching') result(r)
            import :: c_int, c_char, c_long_long
            character(kind=c_char), intent(in) :: dir(*), prefix(*), suffix(*)
                !! NUL-terminated folder, name prefix, suffix
            integer(c_long_long), value :: after    !! -1: every such name
            integer(c_int) :: r
        end function c_remove_matching
        !> 1 if a and b name the same existing file, 0 if two, -1 if either does not exist.
        function c_same_file(a, b) bind(C, name='dc_same_file') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: a(*), b(*)  !! NUL-terminated paths
            integer(c_int) :: r
        end function c_same_file
        !> Remove the lock file if it holds our pid.
        function c_lock_release(path) bind(C, name='dc_lock_release') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated lock file path
            integer(c_int) :: r
        end function c_lock_release
        !> The canonical form of path in out: its length, -1 if it cannot be resolved
        !> (file_paths.c).
        function c_real_path(path, out, len) bind(C, name='dc_real_path') result(r)
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated path
            character(kind=c_char), intent(out) :: out(*)  !! its canonical form, NUL-terminated
            integer(c_int), value :: len                   !! length of out
            integer(c_int) :: r
        end function c_real_path
    end interface

    public :: signals_install, stop_signals_catch, exit_on_read_signal, stop_removes, &
              stop_keeps, gmsh_guard_begin, gmsh_guard_after_init, gmsh_guard_end, fd_open, &
              fd_write, fd_close, file_rename, file_remove, check_writable, lock_take, &
              lock_release, write_text_atomic, sys_error, free_space, fd_sync, fd_reopen, &
              bytes_hash, remove_matching, same_folder, write_status, read_whole_file, real_path

contains

    !> The whole file `path` in `buf`: ok false where it cannot be read (missing,
    !> unreadable, not enough memory) or holds fewer than `min_bytes` bytes.
    subroutine read_whole_file(path, min_bytes, buf, ok)
        character(len=*), intent(in) :: path                    !! the file
        integer, intent(in) :: min_bytes                        !! the fewest bytes it may hold
        character(len=:), allocatable, intent(out) :: buf       !! its bytes
        logical, intent(out) :: ok                              !! it was read
        integer(i8) :: nbytes
        integer :: unit, ios
        ok = .false.
        inquire (file=path, size=nbytes, iostat=ios)
        if (ios /= 0 .or. nbytes < min_bytes) return
        allocate (character(len=nbytes) :: buf, stat=ios)
        if (ios /= 0) return
        open (newunit=unit, file=path, access='stream', form='unformatted', action='read', &
              status='old', iostat=ios)
        if (ios /= 0) return
        read (unit, iostat=ios) buf
        close (unit)
        ok = ios == 0
    end subroutine read_whole_file

    !> The system's text for an errno value.
    function sys_error(err) result(s)
        integer, intent(in) :: err    !! errno
        character(len=:), allocatable :: s
        character(len=128) :: buf
        call c_strerror(int(err, c_int), buf, int(len(buf), c_int))
        s = trim(buf)
    end function sys_error

    !> The status of a write that failed with errno err: STAT_INTERNAL (exit 4) when the
    !> file system has no room or takes no writes (ENOSPC, EDQUOT, EFBIG, EROFS), else
    !> STAT_BAD_INPUT (exit 2: a bad path, a file in the way, no permission).
    function write_status(err) result(stat)
        integer, intent(in) :: err    !! errno
        integer :: stat
        stat = merge(STAT_INTERNAL, STAT_BAD_INPUT, c_errno_no_room(int(err, c_int)) /= 0)
    end function write_status

    !> Bytes and files an unprivileged user may still create in folder dir's file system
    !> (-1 for a count the file system does not report, or when dir cannot be queried).
    subroutine free_space(dir, bytes, files)
        character(len=*), intent(in) :: dir     !! an existing folder
        integer(i8), intent(out) :: bytes       !! free bytes
        integer(i8), intent(out) :: files       !! free file slots (inodes)
        integer(c_int64_t) :: b, f
        b = -1; f = -1
        if (c_free_space(trim(dir)//c_null_char, b, f) /= 0) then
            b = -1; f = -1
        end if
        bytes = int(b, i8); files = int(f, i8)
    end subroutine free_space

    !> Install the SIGINT / SIGTERM handlers (they only set a flag; module stop_signal) and
    !> ignore SIGXFSZ (a write past the file-size limit fails as on a full disk).
    subroutine signals_install(stat, errmsg)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: r
        stat = STAT_OK
        r = c_signals_install()
        if (r /= 0) call raise(stat, errmsg, STAT_INTERNAL, 'cannot install signal handlers: ' &
                               //sys_error(r))
    end subroutine signals_install

    !> For a library caller whose own handler of signal sig (SIGINT or SIGTERM) raises
    !> KeyboardInterrupt, over the core's call that opens a run: the signal then sets the
    !> stop flag (module stop_signal), which the run's set-up reads, until the caller puts
    !> its handler back. A signal the process ignores stays ignored. 0, or errno.
    function stop_signals_catch(sig) result(err)
        integer, intent(in) :: sig   !! SIGINT or SIGTERM
        integer :: err
        err = int(c_stop_signals_catch(int(sig, c_int)))
    end function stop_signals_catch

    !> For a program hosted in another process (the Python command line), never for the
    !> library: from this call on, SIGINT / SIGTERM while gmsh reads a mesh file end the
    !> process, exit status 130 and one line naming the file, as in the executable, whose
    !> handlers (signals_install) mean the same. A switch of the process, never cleared.
    subroutine exit_on_read_signal()
        call c_exit_on_read_signal()
    end subroutine exit_on_read_signal

    !> Name path (a file, or a folder emptied first) for removal when a stop signal ends
    !> the process during a gmsh read (exit_on_read_signal), until stop_keeps(path): a
    !> temporary file written before the read that the exit would otherwise leave behind.
    !> err: 0, or errno (ENAMETOOLONG, or ENOSPC when too many are named).
    subroutine stop_removes(path, err)
        character(len=*), intent(in) :: path   !! file or folder
        integer, intent(out) :: err            !! 0 or errno
        err = c_stop_removes(path//c_null_char)
    end subroutine stop_removes

    !> Take back one naming of path by stop_removes (its writer keeps or removes it).
    subroutine stop_keeps(path)
        character(len=*), intent(in) :: path   !! file or folder
        call c_stop_keeps(path//c_null_char)
    end subroutine stop_keeps

    !> Begin the guard around a program's own calls into gmsh outside the core's reader
    !> (the Python gmsh module): the signal dispositions kept, and in a program that
    !> asked for it (exit_on_read_signal) SIGINT / SIGTERM ending the process at once
    !> with exit status 130 and the line line_start, the signal's number, line_end.
    !> held: whether this call holds the guard (one at a time; see gmsh_shim.c).
    subroutine gmsh_guard_begin(line_start, line_end, held)
        character(len=*), intent(in) :: line_start  !! the line before the signal's number
        character(len=*), intent(in) :: line_end    !! the line after it
        logical, intent(out) :: held                !! the guard is this call's
        held = c_gmsh_guard_begin(line_start//c_null_char, line_end//c_null_char) /= 0
    end subroutine gmsh_guard_begin

    !> Inside the guard, right after gmsh's initialization, which resets some signals'
    !> dispositions: the stop signals' put back at once.
    subroutine gmsh_guard_after_init()
        call c_gmsh_guard_after_init()
    end subroutine gmsh_guard_after_init

    !> End the guard the calling thread began: dispositions and signal mask put back.
    subroutine gmsh_guard_end()
        call c_gmsh_guard_end()
    end subroutine gmsh_guard_end

    !> Open (create or truncate) a file for writing; fd >= 0 on success.
    subroutine fd_open(path, fd, stat, errmsg)
        character(len=*), intent(in) :: path                !! file
        integer, intent(out) :: fd                          !! descriptor
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: r
        stat = STAT_OK
        r = c_fd_open(trim(path)//c_null_char)
        fd = r
        if (r < 0) call raise(stat, errmsg, STAT_INTERNAL, trim(path)//': cannot write: ' &
                              //sys_error(-r))
    end subroutine fd_open

    !> Write all of buf to fd (a short write, e.g. a full disk, is an error).
    subroutine fd_write(fd, buf, path, stat, errmsg)
        integer, intent(in) :: fd                           !! descriptor
        character(len=*), intent(in) :: buf                 !! bytes to write
        character(len=*), intent(in) :: path                !! file name (for the message)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: r
        stat = STAT_OK
        if (len(buf) == 0) return
        r = c_fd_write(int(fd, c_int), buf, int(len(buf), c_long))
        call check_errno(r, path, 'write failed', stat, errmsg)
    end subroutine fd_write

    !> Close fd, reporting a delayed write error.
    subroutine fd_close(fd, path, stat, errmsg)
        integer, intent(in) :: fd                           !! descriptor
        character(len=*), intent(in) :: path                !! file name (for the message)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: r
        r = c_fd_close(int(fd, c_int))
        call check_errno(r, path, 'close failed', stat, errmsg)
    end subroutine fd_close

    !> Flush fd's data to the device (fsync).
    subroutine fd_sync(fd, path, stat, errmsg)
        integer, intent(in) :: fd                           !! descriptor
        character(len=*), intent(in) :: path                !! file name (for the message)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: r
        r = c_fsync(int(fd, c_int))
        call check_errno(r, path, 'fsync failed', stat, errmsg)
    end subroutine fd_sync

    !> Open an existing file for writing, cut back to `bytes` bytes, positioned at its end.
    subroutine fd_reopen(path, bytes, fd, stat, errmsg)
        character(len=*), intent(in) :: path                !! file
        integer(c_long_long), intent(in) :: bytes           !! size to keep
        integer, intent(out) :: fd                          !! descriptor (-1 on failure)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: r
        stat = STAT_OK
        fd = -1
        r = c_fd_reopen(trim(path)//c_null_char, bytes)
        if (r < 0) then
            call raise(stat, errmsg, STAT_INTERNAL, trim(path)//': cannot reopen: '//sys_error(-r))
        else
            fd = r
        end if
    end subroutine fd_reopen

    !> 64-bit FNV-1a hash of the bytes of s, continuing from h (0 to start).
    function bytes_hash(s, h) result(r)
        character(len=*), intent(in) :: s                   !! bytes
        integer(c_long_long), intent(in) :: h               !! hash so far (0 to start)
        integer(c_long_long) :: r
        r = c_hash64(s, int(len(s), c_long_long), h)
    end function bytes_hash

    !> Rename a file (atomic within one file system, replaces `to`).
    subroutine file_rename(from, to, stat, errmsg)
        character(len=*), intent(in) :: from                !! existing file
        character(len=*), intent(in) :: to                  !! new name
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: r
        r = c_rename(trim(from)//c_null_char, trim(to)//c_null_char)
        call check_errno(r, to, 'cannot replace', stat, errmsg)
    end subroutine file_rename

    !> STAT_OK when a system call returned r = 0; otherwise STAT_INTERNAL with
    !> "path: what: <the errno r's text>".
    subroutine check_errno(r, path, what, stat, errmsg)
        integer, intent(in) :: r                            !! 0 or an errno value
        character(len=*), intent(in) :: path                !! file name (for the message)
        character(len=*), intent(in) :: what                !! what failed
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        stat = STAT_OK
        if (r /= 0) call raise(stat, errmsg, STAT_INTERNAL, trim(path)//': '//what//': ' &
                               //sys_error(r))
    end subroutine check_errno

    !> Remove a file if it exists (errors ignored: used for clean-up only).
    subroutine file_remove(path)
        character(len=*), intent(in) :: path   !! file
        integer :: r
        r = c_unlink(trim(path)//c_null_char)
    end subroutine file_remove

    !> Remove the files of folder `dir` named `prefix`*`suffix` (none if the folder does
    !> not exist); with `after`, only those named `prefix`N`suffix` with N a number above
    !> it. STAT_INTERNAL naming the folder if one cannot be removed.
    subroutine remove_matching(dir, prefix, suffix, stat, errmsg, after)
        character(len=*), intent(in) :: dir                 !! folder
        character(len=*), intent(in) :: prefix              !! start of the names
        character(len=*), intent(in) :: suffix              !! end of the names
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(i8), intent(in), optional :: after          !! >= 0: numbers above it only
        integer :: r
        integer(c_long_long) :: above
        above = -1
        if (present(after)) above = int(max(after, 0_i8), c_long_long)
        r = c_remove_matching(trim(dir)//c_null_char, prefix//c_null_char, suffix//c_null_char, &
                              above)
        call check_errno(r, trim(dir)//'/'//prefix//'*'//suffix, 'cannot remove', stat, errmsg)
    end subroutine remove_matching

    !> Whether paths a and b name the same folder: the same device and inode when both
    !> exist ('k', 'k/', './k', its absolute path, a link to it), else the same text.
    function same_folder(a, b) result(same)
        character(len=*), intent(in) :: a   !! a folder
        character(len=*), intent(in) :: b   !! another (or the same) folder
        logical :: same
        integer :: r
        r = c_same_file(trim(a)//c_null_char, trim(b)//c_null_char)
        same = r == 1 .or. (r < 0 .and. trim(a) == trim(b))
    end function same_folder

    !> STAT_INTERNAL if `path` exists and cannot be written by us.
    subroutine check_writable(path, stat, errmsg)
        character(len=*), intent(in) :: path                !! file
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: r
        stat = STAT_OK
        r = c_check_writable(trim(path)//c_null_char)
        if (r /= 0) call raise(stat, errmsg, STAT_INTERNAL, trim(path)//': cannot write: ' &
                               //sys_error(r)//' (previous results left untouched)')
    end subroutine check_writable

    !> Take the lock of an output folder (LOCK_NAME holding our pid, its start, the boot
    !> and the host). A folder locked by a live process, or by a run on another machine
    !> (a shared file system), is STAT_BAD_INPUT; a stale lock (dead pid) is taken over.
    subroutine lock_take(dir, stat, errmsg)
        character(len=*), intent(in) :: dir                 !! output folder
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: r
        character(len=24) :: buf
        character(len=256) :: host
        stat = STAT_OK
        r = c_lock_take(trim(dir)//'/'//LOCK_NAME//c_null_char)
        if (r < 0) then
            write (buf, '(i0)') -r
            if (c_lock_host(trim(dir)//'/'//LOCK_NAME//c_null_char, host, &
                            int(len(host), c_int)) == 1) then
                call raise(stat, errmsg, STAT_BAD_INPUT, trim(dir)//': another run (pid ' &
                           //trim(buf)//' on host '//trim(host)//') is writing into this ' &
                           //'output folder (lock '//LOCK_NAME//'; if no run is left on ' &
                           //trim(host)//', remove '//trim(dir)//'/'//LOCK_NAME//')')
                return
            end if
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(dir)//': another run (pid '//trim(buf) &
                       //') is writing into this output folder (lock '//LOCK_NAME//')')
        else if (r > 0) then
            call raise(stat, errmsg, STAT_INTERNAL, trim(dir)//'/'//LOCK_NAME//': cannot create: ' &
                       //sys_error(r))
        end if
    end subroutine lock_take

    !> Release the lock of an output folder (only if it is ours).
    subroutine lock_release(dir)
        character(len=*), intent(in) :: dir   !! output folder
        integer :: r
        r = c_lock_release(trim(dir)//'/'//LOCK_NAME//c_null_char)
    end subroutine lock_release

    !> Write a whole text file atomically: path.tmp, then rename over path. On any
    !> failure the previous file is left as it was and the temporary one removed;
    !> with `in_place`, a failure is followed by one attempt to rewrite path itself
    !> (a last summary on a full disk, where a second file does not fit).
    recursive subroutine write_text_atomic(path, text, stat, errmsg, in_place)
        character(len=*), intent(in) :: path                !! file
        character(len=*), intent(in) :: text                !! contents
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        logical, intent(in), optional :: in_place           !! fall back to rewriting path
        integer :: fd, st2, r
        character(len=:), allocatable :: tmp
        tmp = trim(path)//'.tmp'
        call fd_open(tmp, fd, stat, errmsg)
        if (stat /= STAT_OK) return
        call fd_write(fd, text, path, stat, errmsg)
        if (stat /= STAT_OK) then
            call fd_close(fd, tmp, st2)
        else
            call fd_close(fd, path, stat, errmsg)
        end if
        if (stat == STAT_OK) call file_rename(tmp, path, stat, errmsg)
        if (stat /= STAT_OK) call file_remove(tmp)
        if (stat == STAT_OK .or. .not. present(in_place)) return
        if (.not. in_place) return
        call fd_open(path, fd, st2)
        if (st2 /= STAT_OK) return
        call fd_write(fd, text, path, st2)
        if (st2 == STAT_OK) then
            call fd_close(fd, path, st2)
        else
            call fd_close(fd, path, r)
        end if
        if (st2 == STAT_OK) stat = STAT_OK
    end subroutine write_text_atomic

    !> The canonical form of `path` (absolute; '.', '..' and symbolic links resolved),
    !> which names one file one way however it is written; `path` itself when it cannot
    !> be resolved (a missing file, a folder we cannot search).
    function real_path(path) result(s)
        character(len=*), intent(in) :: path   !! a file or folder
        character(len=:), allocatable :: s
        integer, parameter :: PATH_MAX_LEN = 4096
        character(kind=c_char) :: buf(PATH_MAX_LEN)
        integer :: n
        n = c_real_path(path//c_null_char, buf, int(PATH_MAX_LEN, c_int))
        if (n < 0) then
            s = path
            return
        end if
        allocate (character(len=n) :: s)
        s = transfer(buf(1:n), s)
    end function real_path
end module os_files
