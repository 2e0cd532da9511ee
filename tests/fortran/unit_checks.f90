!> The check harness of the Fortran unit-test programs: a counter of failed checks
!> (held by the program, no module state), one line per failure, and the closing
!> verdict (exit status 1 through error stop when a check failed); and a reproducible
!> random_number stream for the programs that draw test matrices.
module unit_checks
    implicit none
    private

    !> Failed checks of one test program.
    type, public :: checks_t
        integer :: nfail = 0                 !! checks that failed so far
    contains
        procedure :: check => checks_check
        procedure :: finish => checks_finish
    end type checks_t

    public :: seed

contains

    !> Count and report a failed condition.
    subroutine checks_check(this, cond, what)
        class(checks_t), intent(inout) :: this  !! the program's checks
        logical, intent(in) :: cond            !! condition that must hold
        character(len=*), intent(in) :: what   !! description
        if (.not. cond) then
            this%nfail = this%nfail + 1
            write (*, '(a)') 'FAIL: '//what
        end if
    end subroutine checks_check

    !> The verdict: stop with status 1 when a check failed, else say all passed.
    subroutine checks_finish(this, program_name)
        class(checks_t), intent(in) :: this    !! the program's checks
        character(len=*), intent(in) :: program_name  !! named in the passing line
        if (this%nfail > 0) then
            write (*, '(i0,a)') this%nfail, ' check(s) failed'
            error stop 1
        end if
        write (*, '(a)') program_name//': all checks passed'
    end subroutine checks_finish

    !> Reproducible random_number stream.
    subroutine seed(s)
        integer, intent(in) :: s   !! seed
        integer :: nseed, i
        integer, allocatable :: vals(:)
        call random_seed(size=nseed)
        allocate (vals(nseed))
        vals = [(s + 37 * i, i = 1, nseed)]
        call random_seed(put=vals)
    end subroutine seed
end module unit_checks
