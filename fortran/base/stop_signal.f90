!> The process's stop flag (stop_signal.c): the SIGINT / SIGTERM caught by the handler
!> that the executable installs for its whole run (os_files' signals_install) and a
!> Python caller only over the opening of a run. The time loop reads it before each
!> step; the set-up reads it between its phases and in its long loops, and returns
!> STAT_INTERRUPTED when it is set, so that a run stops within a fraction of a second of
!> the signal instead of after the whole set-up. Set by the handler alone, cleared only
!> for a Python caller once its open is over (signal_take).
module stop_signal
    use iso_c_binding, only: c_int
    use errors, only: STAT_OK, STAT_INTERRUPTED, raise
    implicit none
    private

    interface
        !> The signal caught (0 = none; stop_signal.c).
        function c_signal_caught() bind(C, name='dc_signal_caught') result(r)
            import :: c_int
            integer(c_int) :: r
        end function c_signal_caught
        !> The signal caught (0 = none), the flag cleared (stop_signal.c).
        function c_signal_take() bind(C, name='dc_stop_signal_take') result(r)
            import :: c_int
            integer(c_int) :: r
        end function c_signal_take
    end interface

    public :: signal_caught, signal_take, check_stop

contains

    !> The signal number caught (0 = none: always 0 where no handler sets the flag).
    function signal_caught() result(sig)
        integer :: sig
        sig = int(c_signal_caught())
    end function signal_caught

    !> The signal number caught (0 = none), and the flag cleared: for a Python caller
    !> only, whose own handlers take the signals over again once a run is open.
    function signal_take() result(sig)
        integer :: sig
        sig = int(c_signal_take())
    end function signal_take

    !> STAT_INTERRUPTED (with the message 'interrupted by signal N during WHAT') when a
    !> stop signal has been caught, else stat unchanged: a check between two phases of
    !> a set-up, or between two turns of one of its long loops.
    subroutine check_stop(what, stat, errmsg)
        character(len=*), intent(in) :: what                !! the phase, e.g. 'the assembly'
        integer, intent(inout) :: stat                      !! status (set when stopped)
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=12) :: num
        integer :: sig
        sig = signal_caught()
        if (sig == 0 .or. stat /= STAT_OK) return
        write (num, '(i0)') sig
        call raise(stat, errmsg, STAT_INTERRUPTED, 'interrupted by signal '//trim(num)// &
                   ' during '//what)
    end subroutine check_stop
end module stop_signal
