!> Unit tests of module umfpack: solves against known solutions, reuse of the
!> symbolic analysis, several right-hand sides, singular and inconsistent input,
!> lu_free twice. Exit status 1 (error stop) on any failure.
program test_umfpack
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, MSG_LEN
    use sparse, only: csc_t, csc_from_coo, csc_matvec
    use umfpack, only: lu_t, lu_factor, lu_solve, lu_solve_many, lu_free, lu_rcond, &
                       umfpack_status_text
    use unit_checks, only: checks_t, seed
    implicit none

    real(dp), parameter :: thr = 1.0e-12_dp   ! solves of well-conditioned systems (relative)
    type(checks_t) :: checks

    call test_known_solution()
    call test_refactor_same_pattern()
    call test_many_rhs()
    call test_singular()
    call test_bad_use()
    call test_status_text()

    call checks%finish('test_umfpack')

contains


    !> Non-symmetric, diagonally dominant n x n matrix with about 6 entries per column
    !> (unsorted COO with duplicates), values scaled by s.
    subroutine random_matrix(n, s, a)
        integer, intent(in) :: n          !! size
        real(dp), intent(in) :: s         !! value scale
        type(csc_t), intent(out) :: a     !! matrix
        integer :: m, k, stat
        integer, allocatable :: r(:), c(:)
        real(dp), allocatable :: v(:), u(:)
        m = 5 * n
        allocate (r(m + n), c(m + n), v(m + n), u(m))
        call random_number(u)
        r(1:m) = 1 + int(u * n)
        call random_number(u)
        c(1:m) = 1 + int(u * n)
        call random_number(v)
        v(1:m) = s * (v(1:m) - 0.5_dp)
        do k = 1, n
            r(m + k) = k
            c(m + k) = k
            v(m + k) = s * 4.0_dp
        end do
        call csc_from_coo(n, r, c, v, a, stat)
        call checks%check(stat == STAT_OK, 'random_matrix: built')
    end subroutine random_matrix

    subroutine test_known_solution()
        integer, parameter :: sizes(3) = [1, 10, 500]
        type(csc_t) :: a
        type(lu_t) :: lu
        real(dp), allocatable :: xe(:), b(:), x(:)
        integer :: t, n, stat
        character(len=MSG_LEN) :: msg
        call seed(1)
        do t = 1, size(sizes)
            n = sizes(t)
            call random_matrix(n, 1.0_dp, a)
            allocate (xe(n), b(n), x(n))
            call random_number(xe)
            call csc_matvec(a, xe, b)
            msg = ''
            call lu_factor(lu, a, stat, msg)
            call checks%check(stat == STAT_OK, 'known: factor '//trim(msg))
            call lu_solve(lu, a, b, x, stat, msg)
            call checks%check(stat == STAT_OK, 'known: solve '//trim(msg))
            call checks%check(maxval(abs(x - xe)) <= thr * maxval(abs(xe)), 'known: x = xe')
            call checks%check(lu_rcond(lu) > 0.0_dp, 'known: rcond > 0')
            call lu_free(lu)
            deallocate (xe, b, x)
        end do
    end subroutine test_known_solution

    !> Same pattern, new values: one analysis, two numeric factorizations.
    subroutine test_refactor_same_pattern()
        integer, parameter :: n = 200
        type(csc_t) :: a, a2, b3
        type(lu_t) :: lu
        real(dp) :: xe(n), b(n), x(n)
        integer :: stat
        call seed(2)
        call random_matrix(n, 1.0_dp, a)
        call random_matrix(n, 3.0_dp, b3)       ! another pattern
        a2 = a
        call random_number(a2%val)
        a2%val = a2%val - 0.5_dp
        where (mod([(stat, stat = 1, a2%nnz)], 7) == 0) a2%val = 0.0_dp
        call add_diagonal(a2, 5.0_dp)
        call lu_factor(lu, a, stat)
        call checks%check(stat == STAT_OK .and. lu%analyses == 1 .and. lu%factorizations == 1, &
                   'refactor: first')
        call lu_factor(lu, a2, stat)
        call checks%check(stat == STAT_OK .and. lu%analyses == 1 .and. lu%factorizations == 2, &
                   'refactor: symbolic reused')
        call random_number(xe)
        call csc_matvec(a2, xe, b)
        call lu_solve(lu, a2, b, x, stat)
        call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr, 'refactor: solve a2')
        call lu_factor(lu, b3, stat)
        call checks%check(stat == STAT_OK .and. lu%analyses == 2 .and. lu%factorizations == 3, &
                   'refactor: new pattern analysed')
        call csc_matvec(b3, xe, b)
        call lu_solve(lu, b3, b, x, stat)
        call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr, 'refactor: solve b3')
        call lu_free(lu)
        call lu_free(lu)                         ! twice is safe
        call checks%check(lu%n == 0 .and. lu%factorizations == 3, 'refactor: free keeps counters')
    end subroutine test_refactor_same_pattern

    subroutine test_many_rhs()
        integer, parameter :: n = 100, m = 4
        type(csc_t) :: a
        type(lu_t) :: lu
        real(dp) :: xe(n, m), b(n, m), x(n, m)
        integer :: k, stat
        call seed(3)
        call random_matrix(n, 2.0_dp, a)
        call random_number(xe)
        do k = 1, m
            call csc_matvec(a, xe(:, k), b(:, k))
        end do
        call lu_factor(lu, a, stat)
        call lu_solve_many(lu, a, b, x, stat)
        call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr, 'many: lu_solve_many')
        x = 0.0_dp
        do k = 1, m                              ! several single solves in a row
            call lu_solve(lu, a, b(:, k), x(:, k), stat)
        end do
        call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr, 'many: repeated lu_solve')
        call lu_free(lu)
    end subroutine test_many_rhs

    subroutine test_singular()
        type(csc_t) :: a
        type(lu_t) :: lu
        integer :: stat
        real(dp) :: x(3)
        character(len=MSG_LEN) :: msg
        ! rank 2: third column = first + second
        call csc_from_coo(3, [1, 2, 2, 3, 1, 2, 3], [1, 1, 2, 2, 3, 3, 3], &
                          [1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, 2.0_dp, 1.0_dp], a, stat)
        msg = ''
        call lu_factor(lu, a, stat, msg)
        call checks%check(stat == STAT_NUMERIC, 'singular: STAT_NUMERIC')
        call checks%check(index(msg, 'singular') > 0, 'singular: message '//trim(msg))
        call lu_solve(lu, a, [1.0_dp, 1.0_dp, 1.0_dp], x, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'singular: no solve without factors')
        ! structurally singular: an empty column
        call csc_from_coo(3, [1, 2], [1, 2], [1.0_dp, 1.0_dp], a, stat)
        call lu_factor(lu, a, stat, msg)
        call checks%check(stat == STAT_NUMERIC, 'singular: empty column')
        call lu_free(lu)
    end subroutine test_singular

    subroutine test_bad_use()
        type(csc_t) :: a, empty
        type(lu_t) :: lu
        integer :: stat
        real(dp) :: x(2), y(3)
        character(len=MSG_LEN) :: msg
        msg = ''
        call lu_factor(lu, empty, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: empty matrix')
        call csc_from_coo(3, [1, 2, 3], [1, 2, 3], [1.0_dp, 1.0_dp, 1.0_dp], a, stat)
        call lu_solve(lu, a, [1.0_dp, 1.0_dp, 1.0_dp], y, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: solve before factor')
        call lu_factor(lu, a, stat, msg)
        call lu_solve(lu, a, [1.0_dp, 1.0_dp], x, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: wrong b size')
        call lu_free(lu)
        call lu_free(lu)
    end subroutine test_bad_use

    subroutine test_status_text()
        call checks%check(umfpack_status_text(-8) == 'UMFPACK status -8 (invalid matrix)', 'text: -8')
        call checks%check(umfpack_status_text(-1) == 'UMFPACK status -1 (out of memory)', 'text: -1')
    end subroutine test_status_text

    subroutine add_diagonal(a, d)
        type(csc_t), intent(inout) :: a   !! matrix with a stored diagonal
        real(dp), intent(in) :: d         !! added to each diagonal entry
        integer :: j, k
        do j = 1, a%n
            do k = a%colptr(j) + 1, a%colptr(j + 1)
                if (a%rowind(k) == j - 1) a%val(k) = a%val(k) + d
            end do
        end do
    end subroutine add_diagonal
end program test_umfpack
