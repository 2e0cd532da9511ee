!> Status codes and error reporting helpers. Library code returns a status and
!> an optional message; only programs stop.
module errors
    implicit none
    private

    integer, parameter, public :: STAT_OK = 0            !! success
    integer, parameter, public :: STAT_BAD_INPUT = 2     !! bad scene, mesh or argument
    integer, parameter, public :: STAT_NUMERIC = 3       !! blow-up, Newton failure, singular matrix
    integer, parameter, public :: STAT_INTERNAL = 4      !! solver failure, allocation, I/O writing
    integer, parameter, public :: STAT_INTERRUPTED = 5   !! SIGINT / SIGTERM caught (exit 130)

    integer, parameter, public :: MSG_LEN = 512          !! length of error messages

    public :: raise, stat_name

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
