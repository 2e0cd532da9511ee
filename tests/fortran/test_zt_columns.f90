!> zcache_add_basis (Z T on the node basis, four columns a pass with the rows cut where a
!> column's range starts or ends) against a plain loop, one column after
!> another on its own range: every entry must receive the same additions in the same
!> order, so y must be equal bit for bit. Columns 0 to 11 with random coefficients (some
!> zero: skipped), ranges random, nested, disjoint, equal, touching, one row and empty,
!> over n = 1 to 40 rows. Exit status 1 (error stop) on any failure.
program test_zt_columns
    use kinds, only: dp
    use contact_columns, only: zcache_t, zcache_add_basis
    use unit_checks, only: checks_t, seed
    implicit none
    integer, parameter :: NB = 12, TRIALS = 400
    type(checks_t) :: checks
    type(zcache_t) :: zc
    real(dp), allocatable :: t(:), y(:), yref(:), u(:)
    integer :: trial, n, k, s, lo, hi, nbad
    real(dp) :: r
    character(len=120) :: what

    call seed(3301)
    nbad = 0
    do trial = 1, TRIALS
        call random_number(r)
        n = 1 + int(r * 40)
        zc%n = n
        if (allocated(zc%bslot)) deallocate (zc%bslot, zc%zb, zc%brange, t, y, yref, u)
        allocate (zc%bslot(NB), zc%zb(n, NB), zc%brange(2, NB), t(NB), y(n), yref(n), u(n))
        call random_number(zc%zb)
        zc%zb = zc%zb - 0.5_dp
        call random_number(u)
        y = u - 0.5_dp
        do k = 1, NB
            s = NB + 1 - k                       ! (slots in another order than the vectors)
            zc%bslot(k) = s
            call random_number(r)
            t(k) = r - 0.5_dp
            if (r < 0.2_dp) t(k) = 0.0_dp
            call pick_range(n, trial, k, lo, hi)
            zc%brange(:, s) = [lo, hi]
        end do
        ! the reference: column after column, each on its own range
        yref = y
        do k = 1, NB
            if (t(k) == 0.0_dp) cycle
            s = zc%bslot(k)
            lo = zc%brange(1, s)
            hi = zc%brange(2, s)
            if (hi >= lo) yref(lo:hi) = yref(lo:hi) + t(k) * zc%zb(lo:hi, s)
        end do
        call zcache_add_basis(zc, t, y)
        if (any(y /= yref)) nbad = nbad + 1
        write (what, '(a, i0, a, i0)') 'trial ', trial, ', n = ', n
        call checks%check(all(y == yref), trim(what)//': the same sums bit for bit')
    end do
    call checks%check(nbad == 0, 'every trial bit for bit')
    ! (freed: a leak checker counts what the program still holds at its end as lost)
    deallocate (zc%bslot, zc%zb, zc%brange, t, y, yref, u)
    call checks%finish('test_zt_columns')

contains

    !> A range of rows for vector k: the kinds of overlap the cuts must handle.
    subroutine pick_range(n, trial, k, lo, hi)
        integer, intent(in) :: n, trial, k
        integer, intent(out) :: lo, hi
        real(dp) :: a(2)
        call random_number(a)
        select case (mod(trial + k, 6))
        case (0)                                 ! the whole column
            lo = 1; hi = n
        case (1)                                 ! empty
            lo = 1 + int(a(1) * n); hi = lo - 1
        case (2)                                 ! one row
            lo = 1 + int(a(1) * n); hi = lo
        case (3)                                 ! from the first row (as on the box)
            lo = 1; hi = 1 + int(a(1) * n)
        case default                             ! anywhere
            lo = 1 + int(a(1) * n)
            hi = lo + int(a(2) * (n - lo + 1))
            hi = min(hi, n)
        end select
    end subroutine pick_range
end program test_zt_columns
