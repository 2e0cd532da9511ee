!> dense_lu_factor (by panels of 4 columns, the columns right of a full panel one at a
!> time) against the textbook right-looking LU written out here (per pivot: the pivot
!> search, the interchange of whole rows, the scaling, then a(i, j) - l(i, k) u(k, j) on
!> every later column): the same operations on the same numbers, so the factors and the
!> interchanges must be equal bit for bit, at every order from 1 to 100 (every split of
!> the columns into panels and pairs, the last column alone or not) and on matrices
!> whose pivots need interchanges. dense_lu_solve must then solve A x = b to round-off.
!> Exit status 1 (error stop) on any failure.
program test_dense_lu
    use kinds, only: dp
    use dense_lu, only: dense_lu_factor, dense_lu_solve
    use unit_checks, only: checks_t, seed
    implicit none
    integer, parameter :: NMAX = 100
    type(checks_t) :: checks
    real(dp) :: a0(NMAX, NMAX), a(NMAX, NMAX), r(NMAX, NMAX), x(NMAX), b(NMAX), res
    integer :: piv(NMAX), rpiv(NMAX), n, info, rinfo, trial
    character(len=160) :: what

    call seed(1126)
    do trial = 1, 2
        do n = 1, NMAX
            call random_number(a0(1:n, 1:n))
            a0(1:n, 1:n) = a0(1:n, 1:n) - 0.5_dp
            ! trial 1: diagonally weighted (the Woodbury systems are I + c V^T W U);
            ! trial 2: no weight, so that most pivots interchange rows
            if (trial == 1) call add_identity(n, a0)
            a(1:n, 1:n) = a0(1:n, 1:n)
            r(1:n, 1:n) = a0(1:n, 1:n)
            call dense_lu_factor(n, a, piv, info)
            call textbook_lu(n, r, rpiv, rinfo)
            write (what, '(a, i0, a, i0)') 'trial ', trial, ', n = ', n
            call checks%check(info == 0 .and. rinfo == 0, trim(what)//': no zero pivot')
            call checks%check(all(piv(1:n) == rpiv(1:n)), trim(what)//': the same interchanges')
            call checks%check(all(a(1:n, 1:n) == r(1:n, 1:n)), &
                              trim(what)//': the same factors bit for bit')
            call random_number(x(1:n))
            b(1:n) = matmul(a0(1:n, 1:n), x(1:n))
            call dense_lu_solve(n, a, piv, b)
            ! backward-stable LU with partial pivoting: |x - x^| / |x| within a small
            ! multiple of n eps times the condition number (random matrices of order
            ! <= 100: condition numbers up to ~1e4; 1e-9 leaves a wide margin)
            res = maxval(abs(b(1:n) - x(1:n))) / maxval(abs(x(1:n)))
            call checks%check(res < 1.0e-9_dp, trim(what)//': the solve')
        end do
    end do
    call checks%finish('test_dense_lu')

contains

    subroutine add_identity(n, m)
        integer, intent(in) :: n
        real(dp), intent(inout) :: m(:, :)
        integer :: i
        do i = 1, n
            m(i, i) = m(i, i) + 1.0_dp
        end do
    end subroutine add_identity

    !> The right-looking LU with partial pivoting, one pivot at a time.
    subroutine textbook_lu(n, m, p, info)
        integer, intent(in) :: n
        real(dp), intent(inout) :: m(:, :)
        integer, intent(out) :: p(:), info
        integer :: j, k, q
        real(dp) :: tmp
        info = 0
        do k = 1, n
            q = k - 1 + maxloc(abs(m(k:n, k)), dim=1)
            p(k) = q
            if (m(q, k) == 0.0_dp) then
                info = k
                return
            end if
            do j = 1, n
                tmp = m(k, j)
                m(k, j) = m(q, j)
                m(q, j) = tmp
            end do
            m(k + 1:n, k) = m(k + 1:n, k) / m(k, k)
            do j = k + 1, n
                m(k + 1:n, j) = m(k + 1:n, j) - m(k + 1:n, k) * m(k, j)
            end do
        end do
    end subroutine textbook_lu
end program test_dense_lu
