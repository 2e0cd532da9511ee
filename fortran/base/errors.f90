!> Status codes and error reporting helpers. Library code returns a status and
!> an optional message; only programs stop.
module errors
    use iso_c_binding, only: c_ptr, c_size_t, c_associated
    use kinds, only: dp
    implicit none
    private

    integer, parameter, public :: STAT_OK = 0            !! success
    integer, parameter, public :: STAT_BAD_INPUT = 2     !! bad scene, mesh or argument
    integer, parameter, public :: STAT_NUMERIC = 3       !! blow-up, Newton failure, singular matrix
    integer, parameter, public :: STAT_INTERNAL = 4      !! solver failure, allocation, I/O writing
    integer, parameter, public :: STAT_INTERRUPTED = 5   !! SIGINT / SIGTERM caught (exit 130)

    integer, parameter, public :: MSG_LEN = 512          !! length of error messages

    !> What to do about a run that ran out of memory, by what needs the memory (the end of
    !> oom_text's line): the matrices of the mesh (only a coarser mesh is smaller), or a
    !> factor (conjugate gradients need none).
    character(len=*), parameter, public :: OOM_HINT_MESH = &
        'use a coarser mesh (a larger &mesh h) or allow the run more memory'
    character(len=*), parameter, public :: OOM_HINT_FACTOR = &
        'use a coarser mesh (a larger &mesh h), &solver kind = ''cg'' (it needs no factor)'// &
        ' or allow the run more memory'

    public :: raise, stat_name, oom_text, is_oom_text, mb_text, has_room

    interface
        !> C malloc().
        function c_malloc(size) result(p) bind(C, name='malloc')
            import :: c_ptr, c_size_t
            integer(c_size_t), value :: size     !! bytes
            type(c_ptr) :: p
        end function c_malloc

        !> C free().
        subroutine c_free(p) bind(C, name='free')
            import :: c_ptr
            type(c_ptr), value :: p              !! block (or null)
        end subroutine c_free
    end interface

contains

    !> Set `stat` to `code` and, if present, `errmsg` to `msg`.
    pure subroutine raise(stat, errmsg, code, msg)
        integer, intent(out) :: stat                       !! status to set
        character(len=*), intent(inout), optional :: errmsg !! message buffer
        integer, intent(in) :: code                        !! one of STAT_*
        character(len=*), intent(in) :: msg                !! one-line message
        stat = code
        if (present(errmsg)) errmsg = msg
    end subroutine raise

    !> The one line of a stage that ran out of memory: 'out of memory in STAGE' (the
    !> assembly, the ordering, the factorization, the contact columns, ...), then ': WHAT'
    !> when what it was trying to hold is known ('' otherwise), then '; HINT' (OOM_HINT_*).
    pure function oom_text(stage, what, hint) result(msg)
        character(len=*), intent(in) :: stage  !! what ran out of memory
        character(len=*), intent(in) :: what   !! what it was to hold ('' unknown)
        character(len=*), intent(in) :: hint   !! what to do
        character(len=:), allocatable :: msg
        msg = 'out of memory in '//stage
        if (len_trim(what) > 0) msg = msg//': '//trim(what)
        msg = msg//'; '//hint
    end function oom_text

    !> Whether `msg` is an out-of-memory line of oom_text (it begins 'out of memory'): how a
    !> caller that gets STAT_INTERNAL tells an allocation that failed from other failures.
    pure logical function is_oom_text(msg)
        character(len=*), intent(in) :: msg    !! a message
        is_oom_text = index(msg, 'out of memory') == 1
    end function is_oom_text

    !> Whether `bytes` could be allocated now: allocated and freed at once, never touched
    !> (under a limit of the address space, ulimit -v, that is the test; without one it
    !> costs a call). A stage that is to allocate that much asks first, so that it fails
    !> with its own line (oom_text) before the allocations that have no status.
    function has_room(bytes) result(ok)
        real(dp), intent(in) :: bytes          !! bytes (<= 0: always room)
        logical :: ok
        type(c_ptr) :: p
        ok = .true.
        if (bytes <= 0.0_dp) return
        ok = bytes < real(huge(1_c_size_t), dp) / 2
        if (.not. ok) return
        p = c_malloc(int(bytes, c_size_t))
        ok = c_associated(p)
        if (ok) call c_free(p)
    end function has_room

    !> A size in bytes as whole megabytes (10^6 bytes, rounded up): '137 MB'.
    pure function mb_text(bytes) result(s)
        real(dp), intent(in) :: bytes          !! bytes (>= 0)
        character(len=:), allocatable :: s
        character(len=24) :: buf
        write (buf, '(i0, a)') int(min(ceiling(max(bytes, 0.0_dp) / 1.0e6_dp), huge(1))), ' MB'
        s = trim(buf)
    end function mb_text

    !> Short name of a status code.
    pure function stat_name(code) result(name)
        integer, intent(in) :: code   !! one of STAT_*
        character(len=:), allocatable :: name
        select case (code)
        case (STAT_OK); name = 'ok'
        case (STAT_BAD_INPUT); name = 'bad_input'
        case (STAT_NUMERIC); name = 'numeric_failure'
        case (STAT_INTERRUPTED); name = 'interrupted'
        case default; name = 'internal_error'
        end select
    end function stat_name
end module errors
