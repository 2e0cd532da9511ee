!> Unit tests of modules cholmod and linear_solver: LDL^T solves against known
!> solutions (full symmetric matrix and upper triangle only), reuse of the analysis,
!> blocked solves, bad pivots, the solver choice (symmetric positive definite ->
!> CHOLMOD, indefinite or non-symmetric -> UMFPACK, exact either way), singular
!> matrices, the symmetry test, the solve by 2x2 node blocks (ldl_solves) against
!> cholmod_solve2 and known solutions; a matrix given as values on another's pattern
!> (`val`) against the same matrix with its own values, bit for bit. Exit status 1
!> (error stop) on any failure.
program test_cholmod
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, MSG_LEN
    use sparse, only: csc_t, csc_from_coo, csc_matvec
    use cholmod, only: cholmod_t, chol_factor, chol_solve, chol_solve_many, chol_free, &
                       chol_kernel, chol_solve_cholmod, chol_ordering, KERNEL_PAIRS, KERNEL_CHOLMOD
    use ldl_solves, only: pair_ldl_t, pair_ldl_build
    use linear_solver, only: factor_t, ls_factor, ls_solve, ls_solve_many, ls_free, &
                             csc_is_symmetric, ls_configure, BACKEND_CHOLMOD, BACKEND_UMFPACK, &
                             BACKEND_PCG, SYM_RTOL
    use unit_checks, only: checks_t, seed
    implicit none

    real(dp), parameter :: thr = 1.0e-12_dp   ! solves of well-conditioned systems (relative)
    type(checks_t) :: checks

    call test_known_solution()
    call test_upper_triangle_only()
    call test_refactor()
    call test_many_rhs()
    call test_bad_pivot()
    call test_choice_spd_nonsymmetric()
    call test_choice_indefinite()
    call test_singular()
    call test_symmetry_test()
    call test_bad_use()
    call test_node_pairs()
    call test_node_pairs_refused()
    call test_pair_layout_checked()
    call test_values_on_pattern()

    call checks%finish('test_cholmod')

contains


    !> Symmetric n x n matrix S + S^T + D with about 6 entries per column (unsorted COO
    !> with duplicates), off-diagonals in s (-1/2, 1/2); D_kk = shift + the Gershgorin
    !> radius of row k (diagonally dominant: SPD for shift > s), with alternating signs
    !> when indefinite (still well conditioned); upper = .true. keeps the upper triangle.
    subroutine sym_matrix(n, s, shift, a, upper, indefinite)
        integer, intent(in) :: n             !! size
        real(dp), intent(in) :: s            !! off-diagonal scale
        real(dp), intent(in) :: shift        !! diagonal margin (> s)
        type(csc_t), intent(out) :: a        !! matrix
        logical, intent(in), optional :: upper      !! upper triangle only
        logical, intent(in), optional :: indefinite !! D_kk sign (-1)^k
        integer :: m, k, stat, i, j
        integer, allocatable :: r(:), c(:)
        real(dp), allocatable :: v(:), u(:)
        logical :: up, indef
        up = .false.
        if (present(upper)) up = upper
        indef = .false.
        if (present(indefinite)) indef = indefinite
        m = 3 * n
        allocate (r(2 * m + n), c(2 * m + n), v(2 * m + n), u(m))
        call random_number(u)
        r(1:m) = 1 + int(u * n)
        call random_number(u)
        c(1:m) = 1 + int(u * n)
        call random_number(v(1:m))
        v(1:m) = s * (v(1:m) - 0.5_dp)
        where (r(1:m) == c(1:m)) v(1:m) = 0.0_dp
        r(m + 1:2 * m) = c(1:m)
        c(m + 1:2 * m) = r(1:m)
        v(m + 1:2 * m) = v(1:m)
        do k = 1, n
            r(2 * m + k) = k
            c(2 * m + k) = k
            v(2 * m + k) = shift + sum(abs(v(1:2 * m)), mask=r(1:2 * m) == k)
            if (indef .and. mod(k, 2) == 0) v(2 * m + k) = -v(2 * m + k)
        end do
        if (up) then
            do k = 1, 2 * m + n
                i = r(k); j = c(k)
                if (i > j) v(k) = 0.0_dp
            end do
        end if
        call csc_from_coo(n, r, c, v, a, stat)
        call checks%check(stat == STAT_OK, 'sym_matrix: built')
    end subroutine sym_matrix

    !> b = A xe for the full symmetric matrix whose upper triangle a holds.
    subroutine sym_matvec_upper(a, x, y)
        type(csc_t), intent(in) :: a   !! upper triangle
        real(dp), intent(in) :: x(:)   !! vector
        real(dp), intent(out) :: y(:)  !! A x
        integer :: i, j, k
        y = 0.0_dp
        do j = 1, a%n
            do k = a%colptr(j) + 1, a%colptr(j + 1)
                i = a%rowind(k) + 1
                if (i > j) cycle
                y(i) = y(i) + a%val(k) * x(j)
                if (i /= j) y(j) = y(j) + a%val(k) * x(i)
            end do
        end do
    end subroutine sym_matvec_upper

    subroutine test_known_solution()
        integer, parameter :: sizes(3) = [1, 10, 500]
        type(csc_t) :: a
        type(cholmod_t) :: ch
        real(dp), allocatable :: xe(:), b(:), x(:)
        integer :: t, n, stat
        character(len=MSG_LEN) :: msg
        call seed(1)
        do t = 1, size(sizes)
            n = sizes(t)
            call sym_matrix(n, 1.0_dp, 1.0_dp, a)
            allocate (xe(n), b(n), x(n))
            call random_number(xe)
            call csc_matvec(a, xe, b)
            msg = ''
            call chol_factor(ch, a, stat, msg)
            call checks%check(stat == STAT_OK, 'known: factor '//trim(msg))
            call checks%check(ch%lnz >= 0 .and. ch%lnz <= n * (n - 1) / 2, 'known: lnz in range')
            call chol_solve(ch, b, x, stat, msg)
            call checks%check(stat == STAT_OK, 'known: solve '//trim(msg))
            call checks%check(maxval(abs(x - xe)) <= thr * maxval(abs(xe)), 'known: x = xe')
            call chol_free(ch)
            deallocate (xe, b, x)
        end do
    end subroutine test_known_solution

    !> Only the upper triangle is read: the same solution from the upper triangle alone.
    subroutine test_upper_triangle_only()
        integer, parameter :: n = 300
        type(csc_t) :: a
        type(cholmod_t) :: ch
        real(dp) :: xe(n), b(n), x(n)
        integer :: stat
        call seed(5)
        call sym_matrix(n, 1.0_dp, 1.0_dp, a, upper=.true.)
        call random_number(xe)
        call sym_matvec_upper(a, xe, b)
        call chol_factor(ch, a, stat)
        call chol_solve(ch, b, x, stat)
        call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr * maxval(abs(xe)), &
                   'upper: x = xe')
        call chol_free(ch)
    end subroutine test_upper_triangle_only

    !> Same pattern, new values: one analysis; a new pattern: a new analysis.
    subroutine test_refactor()
        integer, parameter :: n = 200
        type(csc_t) :: a, a2, b3
        type(cholmod_t) :: ch
        real(dp) :: xe(n), b(n), x(n)
        integer :: stat
        call seed(2)
        call sym_matrix(n, 1.0_dp, 1.0_dp, a)
        call sym_matrix(n, 2.0_dp, 1.0_dp, b3)
        a2 = a
        a2%val = 2.0_dp * a%val
        call chol_factor(ch, a, stat)
        call checks%check(stat == STAT_OK .and. ch%analyses == 1 .and. ch%factorizations == 1, &
                   'refactor: first')
        call chol_factor(ch, a2, stat)
        call checks%check(stat == STAT_OK .and. ch%analyses == 1 .and. ch%factorizations == 2, &
                   'refactor: analysis reused')
        call random_number(xe)
        call csc_matvec(a2, xe, b)
        call chol_solve(ch, b, x, stat)
        call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr, 'refactor: solve a2')
        call chol_factor(ch, b3, stat)
        call checks%check(stat == STAT_OK .and. ch%analyses == 2 .and. ch%factorizations == 3, &
                   'refactor: new pattern analysed')
        call csc_matvec(b3, xe, b)
        call chol_solve(ch, b, x, stat)
        call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr, 'refactor: solve b3')
        call chol_free(ch)
        call chol_free(ch)                       ! twice is safe
        call checks%check(ch%n == 0 .and. ch%factorizations == 3, 'refactor: free keeps counters')
    end subroutine test_refactor

    subroutine test_many_rhs()
        integer, parameter :: n = 100, m = 5
        type(csc_t) :: a
        type(cholmod_t) :: ch
        type(factor_t) :: f
        real(dp) :: xe(n, m), b(n, m), x(n, m)
        integer :: k, stat
        call seed(3)
        call sym_matrix(n, 1.0_dp, 1.0_dp, a)
        call random_number(xe)
        do k = 1, m
            call csc_matvec(a, xe(:, k), b(:, k))
        end do
        call chol_factor(ch, a, stat)
        call chol_solve_many(ch, b, x, stat)
        call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr, 'many: chol_solve_many')
        call chol_solve_many(ch, b(:, 1:2), x(:, 1:2), stat)   ! fewer columns: workspace resized
        call checks%check(stat == STAT_OK .and. maxval(abs(x(:, 1:2) - xe(:, 1:2))) <= thr, &
                   'many: two columns')
        call chol_free(ch)
        call ls_factor(f, a, stat)
        x = 0.0_dp
        call ls_solve_many(f, a, b, x, stat)
        call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr, 'many: ls_solve_many')
        call ls_free(f)
    end subroutine test_many_rhs

    !> Negative and zero pivots: STAT_NUMERIC, no factors to solve with.
    subroutine test_bad_pivot()
        type(csc_t) :: a
        type(cholmod_t) :: ch
        integer :: stat
        real(dp) :: x(2)
        character(len=MSG_LEN) :: msg
        ! [[1, 2], [2, 1]]: eigenvalues 3 and -1
        call csc_from_coo(2, [1, 2, 1, 2], [1, 1, 2, 2], [1.0_dp, 2.0_dp, 2.0_dp, 1.0_dp], a, stat)
        msg = ''
        call chol_factor(ch, a, stat, msg)
        call checks%check(stat == STAT_NUMERIC, 'pivot: indefinite gives STAT_NUMERIC')
        call checks%check(index(msg, 'not positive definite') > 0, 'pivot: message '//trim(msg))
        call chol_solve(ch, [1.0_dp, 1.0_dp], x, stat)
        call checks%check(stat == STAT_BAD_INPUT, 'pivot: no solve without factors')
        ! [[1, 1], [1, 1]]: zero pivot
        call csc_from_coo(2, [1, 2, 1, 2], [1, 1, 2, 2], [1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp], a, stat)
        call chol_factor(ch, a, stat, msg)
        call checks%check(stat == STAT_NUMERIC, 'pivot: zero pivot gives STAT_NUMERIC')
        call chol_free(ch)
    end subroutine test_bad_pivot

    !> The solver choice for a: xe drawn from the random stream, b = A xe; ls_factor
    !> must succeed on `backend` with f%symmetric = symmetric (and f%fell_back =
    !> fell_back when given), checked as name//': '//choice; then ls_solve must give
    !> x = xe to thr relative to max|xe|, checked as name//': x = xe'.
    subroutine check_choice(f, a, xe, backend, symmetric, name, choice, fell_back)
        type(factor_t), intent(inout) :: f          !! factor (left factorized)
        type(csc_t), intent(in) :: a                !! matrix
        real(dp), intent(out) :: xe(:)              !! the drawn solution (size a%n)
        character(len=*), intent(in) :: backend     !! backend the choice must make
        logical, intent(in) :: symmetric            !! f%symmetric expected
        character(len=*), intent(in) :: name        !! the checks' prefix
        character(len=*), intent(in) :: choice      !! the choice check's description
        logical, intent(in), optional :: fell_back  !! f%fell_back expected
        real(dp) :: b(size(xe)), x(size(xe))
        logical :: fell_back_ok
        integer :: stat
        call random_number(xe)
        call csc_matvec(a, xe, b)
        call ls_factor(f, a, stat)
        fell_back_ok = .true.
        if (present(fell_back)) fell_back_ok = f%fell_back .eqv. fell_back
        call checks%check(stat == STAT_OK .and. f%backend == backend .and. &
                          (f%symmetric .eqv. symmetric) .and. fell_back_ok, name//': '//choice)
        call ls_solve(f, a, b, x, stat)
        call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr * maxval(abs(xe)), &
                          name//': x = xe')
    end subroutine check_choice

    !> SPD (n = 400): CHOLMOD LDL^T; non-symmetric (n = 200, one strictly-upper entry
    !> scaled): UMFPACK.
    subroutine test_choice_spd_nonsymmetric()
        type(csc_t) :: spd, nonsym
        type(factor_t) :: f_spd, f_nonsym
        real(dp) :: xe_spd(400), xe_nonsym(200)
        call seed(4)
        call sym_matrix(400, 1.0_dp, 1.0_dp, spd)
        call check_choice(f_spd, spd, xe_spd, BACKEND_CHOLMOD, .true., 'spd', 'CHOLMOD LDL^T', &
                          fell_back=.false.)
        call ls_free(f_spd)
        call seed(7)
        call sym_matrix(200, 1.0_dp, 1.0_dp, nonsym)
        call perturb_off_diagonal(nonsym)
        call checks%check(.not. csc_is_symmetric(nonsym), 'nonsymmetric: detected')
        call check_choice(f_nonsym, nonsym, xe_nonsym, BACKEND_UMFPACK, .false., 'nonsymmetric', &
                          'UMFPACK')
        call ls_free(f_nonsym)
    end subroutine test_choice_spd_nonsymmetric

    !> Symmetric indefinite (diagonal of alternating sign): LDL^T meets a negative pivot,
    !> UMFPACK solves it exactly; refactorizing an SPD matrix afterwards goes back to CHOLMOD.
    subroutine test_choice_indefinite()
        integer, parameter :: n = 300
        type(csc_t) :: a, spd
        type(factor_t) :: f
        real(dp) :: xe(n), b(n), x(n)
        integer :: stat
        call seed(6)
        call sym_matrix(n, 1.0_dp, 1.0_dp, a, indefinite=.true.)
        call check_choice(f, a, xe, BACKEND_UMFPACK, .true., 'indefinite', &
                          'fell back to UMFPACK', fell_back=.true.)
        call sym_matrix(n, 1.0_dp, 1.0_dp, spd)
        call ls_factor(f, spd, stat)
        call checks%check(stat == STAT_OK .and. f%backend == BACKEND_CHOLMOD, 'indefinite: back to CHOLMOD')
        call csc_matvec(spd, xe, b)
        call ls_solve(f, spd, b, x, stat)
        call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr, 'indefinite: then SPD solve')
        call checks%check(f%factorizations == 2, 'indefinite: two factorizations counted')
        call ls_free(f)
    end subroutine test_choice_indefinite

    !> Multiply the first strictly-upper entry by 1.5 (its lower partner unchanged).
    subroutine perturb_off_diagonal(a)
        type(csc_t), intent(inout) :: a   !! symmetric matrix
        integer :: j, k
        do j = 1, a%n
            do k = a%colptr(j) + 1, a%colptr(j + 1)
                if (a%rowind(k) + 1 < j .and. a%val(k) /= 0.0_dp) then
                    a%val(k) = 1.5_dp * a%val(k)
                    return
                end if
            end do
        end do
    end subroutine perturb_off_diagonal

    subroutine test_singular()
        type(csc_t) :: a
        type(factor_t) :: f
        integer :: stat
        real(dp) :: x(3)
        character(len=MSG_LEN) :: msg
        ! symmetric, rank 2: row 3 = row 1 + row 2
        call csc_from_coo(3, [1, 2, 3, 1, 2, 3, 1, 2, 3], [1, 1, 1, 2, 2, 2, 3, 3, 3], &
                          [2.0_dp, 1.0_dp, 3.0_dp, 1.0_dp, 2.0_dp, 3.0_dp, 3.0_dp, 3.0_dp, &
                           6.0_dp], a, stat)
        call checks%check(csc_is_symmetric(a), 'singular: symmetric')
        msg = ''
        call ls_factor(f, a, stat, msg)
        call checks%check(stat == STAT_NUMERIC, 'singular: STAT_NUMERIC')
        call checks%check(index(msg, 'singular') > 0, 'singular: message '//trim(msg))
        call checks%check(f%backend == '', 'singular: no backend')
        call ls_solve(f, a, [1.0_dp, 1.0_dp, 1.0_dp], x, stat)
        call checks%check(stat == STAT_BAD_INPUT, 'singular: no solve without factors')
        call ls_free(f)
    end subroutine test_singular

    !> Round-off asymmetry is accepted, a larger one or a missing partner is not.
    subroutine test_symmetry_test()
        type(csc_t) :: a
        integer :: stat
        real(dp) :: e
        e = 0.1_dp * SYM_RTOL
        call csc_from_coo(2, [1, 2, 1, 2], [1, 1, 2, 2], [4.0_dp, 1.0_dp, 1.0_dp + e, 4.0_dp], &
                          a, stat)
        call checks%check(csc_is_symmetric(a), 'symmetry: round-off accepted')
        e = 10.0_dp * SYM_RTOL * 4.0_dp
        call csc_from_coo(2, [1, 2, 1, 2], [1, 1, 2, 2], [4.0_dp, 1.0_dp, 1.0_dp + e, 4.0_dp], &
                          a, stat)
        call checks%check(.not. csc_is_symmetric(a), 'symmetry: 10 SYM_RTOL rejected')
        ! near-cancelled pair: judged against the diagonal scale
        call csc_from_coo(2, [1, 2, 1, 2], [1, 1, 2, 2], [4.0_dp, 1.0e-30_dp, 2.0e-30_dp, 4.0_dp], &
                          a, stat)
        call checks%check(csc_is_symmetric(a), 'symmetry: tiny pair against the diagonal')
        call csc_from_coo(2, [1, 2, 2], [1, 1, 2], [4.0_dp, 1.0_dp, 4.0_dp], a, stat)
        call checks%check(.not. csc_is_symmetric(a), 'symmetry: missing partner')
        call csc_from_coo(2, [1, 2, 2, 1], [1, 1, 2, 2], [4.0_dp, 1.0_dp, 4.0_dp, 0.0_dp], a, stat)
        call checks%check(.not. csc_is_symmetric(a), 'symmetry: stored zero partner of a nonzero')
    end subroutine test_symmetry_test

    subroutine test_bad_use()
        type(csc_t) :: a, empty
        type(cholmod_t) :: ch
        type(factor_t) :: f
        integer :: stat
        real(dp) :: x(2), y(3)
        character(len=MSG_LEN) :: msg
        msg = ''
        call chol_factor(ch, empty, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: empty matrix (cholmod)')
        call ls_factor(f, empty, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: empty matrix (linear_solver)')
        call csc_from_coo(3, [1, 2, 3], [1, 2, 3], [1.0_dp, 1.0_dp, 1.0_dp], a, stat)
        call ls_solve(f, a, [1.0_dp, 1.0_dp, 1.0_dp], y, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: solve before factor')
        call ls_factor(f, a, stat, msg)
        call checks%check(stat == STAT_OK .and. f%backend == BACKEND_CHOLMOD, 'bad: identity by CHOLMOD')
        call ls_solve(f, a, [1.0_dp, 1.0_dp], x, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: wrong b size')
        call ls_free(f)
        call ls_free(f)
        call chol_free(ch)
    end subroutine test_bad_use

    !> A symmetric matrix of full 2x2 blocks on a random node pattern (nn nodes, about
    !> 3 neighbours each, diagonally dominant: SPD); drop_one removes one entry of one
    !> off-diagonal block pair (then it is not made of whole blocks).
    subroutine pair_matrix(nn, a, drop_one, upper)
        integer, intent(in) :: nn                    !! nodes (n = 2 nn)
        type(csc_t), intent(out) :: a                !! matrix
        logical, intent(in), optional :: drop_one    !! break one block
        logical, intent(in), optional :: upper       !! upper triangle only
        integer :: m, k, i, j, q, stat, cnt
        integer, allocatable :: ni(:), nj(:), r(:), c(:)
        real(dp), allocatable :: u(:), v(:), blk(:, :), dsum(:)
        m = 3 * nn
        allocate (ni(m), nj(m), u(m), blk(4, m), r(8 * m + 4 * nn), c(8 * m + 4 * nn), &
                  v(8 * m + 4 * nn), dsum(2 * nn))
        call random_number(u)
        ni = 1 + int(u * nn)
        call random_number(u)
        nj = 1 + int(u * nn)
        call random_number(blk)
        blk = blk - 0.5_dp
        cnt = 0
        dsum = 0.0_dp
        do k = 1, m
            if (ni(k) == nj(k)) cycle
            do q = 1, 4      ! block (I, J) entry q = (i, j) and its mirror (j, i)
                i = 2 * ni(k) - 1 + mod(q - 1, 2)
                j = 2 * nj(k) - 1 + (q - 1) / 2
                if (present(drop_one)) then
                    if (drop_one .and. k == 1 .and. q == 2) cycle
                end if
                cnt = cnt + 1; r(cnt) = i; c(cnt) = j; v(cnt) = blk(q, k)
                cnt = cnt + 1; r(cnt) = j; c(cnt) = i; v(cnt) = blk(q, k)
                dsum(i) = dsum(i) + abs(blk(q, k))
                dsum(j) = dsum(j) + abs(blk(q, k))
            end do
        end do
        do k = 1, nn     ! diagonal blocks [d1 e; e d2]
            i = 2 * k - 1
            cnt = cnt + 1; r(cnt) = i; c(cnt) = i + 1; v(cnt) = 0.25_dp
            cnt = cnt + 1; r(cnt) = i + 1; c(cnt) = i; v(cnt) = 0.25_dp
            cnt = cnt + 1; r(cnt) = i; c(cnt) = i; v(cnt) = 1.0_dp + dsum(i)
            cnt = cnt + 1; r(cnt) = i + 1; c(cnt) = i + 1; v(cnt) = 1.0_dp + dsum(i + 1)
        end do
        if (present(upper)) then
            if (upper) where (r(1:cnt) > c(1:cnt)) v(1:cnt) = 0.0_dp
        end if
        call csc_from_coo(2 * nn, r(1:cnt), c(1:cnt), v(1:cnt), a, stat)
        call checks%check(stat == STAT_OK, 'pair_matrix: built')
    end subroutine pair_matrix

    !> A matrix of node pairs is solved by 2x2 blocks: the known solution, the same
    !> numbers as cholmod_solve2 on the same factor to round-off, several right-hand
    !> sides, a refactorization, the upper triangle alone.
    subroutine test_node_pairs()
        integer, parameter :: sizes(3) = [1, 7, 400]
        type(csc_t) :: a, a2
        type(cholmod_t) :: ch
        type(factor_t) :: f
        real(dp), allocatable :: xe(:, :), b(:, :), x(:, :), xc(:)
        integer :: t, n, stat, k, analyses
        call seed(11)
        do t = 1, size(sizes)
            n = 2 * sizes(t)
            call pair_matrix(sizes(t), a)
            allocate (xe(n, 3), b(n, 3), x(n, 3), xc(n))
            call random_number(xe)
            do k = 1, 3
                call csc_matvec(a, xe(:, k), b(:, k))
            end do
            call chol_factor(ch, a, stat)
            call checks%check(stat == STAT_OK .and. chol_kernel(ch) == KERNEL_PAIRS, &
                              'pairs: factor, kernel')
            call chol_solve(ch, b(:, 1), x(:, 1), stat)
            call checks%check(stat == STAT_OK .and. maxval(abs(x(:, 1) - xe(:, 1))) <= thr, &
                              'pairs: x = xe')
            ! one copy of the factor: CHOLMOD's was released after the block copy
            call chol_solve_cholmod(ch, b(:, 1), xc, stat)
            call checks%check(stat == STAT_BAD_INPUT .and. ch%pairs%n == n, &
                              'pairs: CHOLMOD''s copy released')
            call checks%check(any(chol_ordering(ch) == ['amd   ', 'metis ', 'nesdis']) .and. &
                              ch%factor_nnz == ch%lnz + n, 'pairs: ordering, factor entries')
            ch%keep_cholmod = .true.
            call chol_factor(ch, a, stat)
            call chol_solve_cholmod(ch, b(:, 1), xc, stat)
            call checks%check(stat == STAT_OK .and. maxval(abs(x(:, 1) - xc)) <= thr, &
                              'pairs: same as cholmod_solve2')
            ch%keep_cholmod = .false.
            x = 0.0_dp
            call chol_solve_many(ch, b, x, stat)
            call checks%check(stat == STAT_OK .and. maxval(abs(x - xe)) <= thr, 'pairs: many')
            a2 = a
            a2%val = 3.0_dp * a%val
            analyses = ch%analyses
            call chol_factor(ch, a2, stat)
            call chol_solve(ch, b(:, 2), x(:, 2), stat)
            call checks%check(stat == STAT_OK .and. ch%analyses == analyses .and. &
                              chol_kernel(ch) == KERNEL_PAIRS .and. &
                              maxval(abs(3.0_dp * x(:, 2) - xe(:, 2))) <= thr, 'pairs: refactor')
            call chol_free(ch)
            call checks%check(chol_kernel(ch) == '', 'pairs: freed')
            call ls_factor(f, a, stat)
            call ls_solve(f, a, b(:, 3), x(:, 3), stat)
            call checks%check(stat == STAT_OK .and. f%backend == BACKEND_CHOLMOD .and. &
                              maxval(abs(x(:, 3) - xe(:, 3))) <= thr, 'pairs: ls_solve')
            call ls_free(f)
            deallocate (xe, b, x, xc)
        end do
        ! the upper triangle alone is read the same way
        call seed(12)
        call pair_matrix(50, a)
        call seed(12)
        call pair_matrix(50, a2, upper=.true.)
        allocate (xe(100, 1), b(100, 1), x(100, 1))
        call random_number(xe)
        call csc_matvec(a, xe(:, 1), b(:, 1))
        call chol_factor(ch, a2, stat)
        call chol_solve(ch, b(:, 1), x(:, 1), stat)
        call checks%check(stat == STAT_OK .and. chol_kernel(ch) == KERNEL_PAIRS .and. &
                          maxval(abs(x - xe)) <= thr, 'pairs: upper triangle only')
        call chol_free(ch)
    end subroutine test_node_pairs

    !> Not made of whole 2x2 blocks (one entry of a block missing, or an odd size):
    !> cholmod_solve2, exact all the same.
    subroutine test_node_pairs_refused()
        type(csc_t) :: a
        type(cholmod_t) :: ch
        real(dp) :: xe(60), b(60), x(60)
        integer :: stat
        call seed(13)
        call pair_matrix(30, a, drop_one=.true.)
        call random_number(xe)
        call csc_matvec(a, xe, b)
        call chol_factor(ch, a, stat)
        call chol_solve(ch, b, x, stat)
        call checks%check(stat == STAT_OK .and. chol_kernel(ch) == KERNEL_CHOLMOD .and. &
                          maxval(abs(x - xe)) <= thr, 'refused: a block with a hole')
        call sym_matrix(59, 1.0_dp, 1.0_dp, a)
        call csc_matvec(a, xe(1:59), b(1:59))
        call chol_factor(ch, a, stat)
        call chol_solve(ch, b(1:59), x(1:59), stat)
        call checks%check(stat == STAT_OK .and. chol_kernel(ch) == KERNEL_CHOLMOD .and. &
                          maxval(abs(x(1:59) - xe(1:59))) <= thr, 'refused: odd size')
        call chol_free(ch)
    end subroutine test_node_pairs_refused

    !> pair_ldl_build checks the structure it is given: a factor whose column 1 lacks
    !> row 2, or whose block rows are not pairs, is refused.
    subroutine test_pair_layout_checked()
        type(pair_ldl_t) :: f
        logical :: ok
        ! 4 x 4, block columns (1,2), (3,4): column 1 = {1, 2, 3, 4}, 2 = {2, 3, 4}
        call pair_ldl_build(f, 4, [0, 1, 2, 3], [0, 4, 7, 9, 10], &
                            [0, 1, 2, 3, 1, 2, 3, 2, 3, 3], &
                            [1.0_dp, 0.1_dp, 0.2_dp, 0.3_dp, 1.0_dp, 0.4_dp, 0.5_dp, 1.0_dp, &
                             0.6_dp, 1.0_dp], ok)
        call checks%check(ok .and. f%n == 4 .and. size(f%bi) == 1, 'layout: whole blocks')
        ! column 1 without row 2
        call pair_ldl_build(f, 4, [0, 1, 2, 3], [0, 3, 6, 8, 9], &
                            [0, 2, 3, 1, 2, 3, 2, 3, 3], &
                            [1.0_dp, 0.2_dp, 0.3_dp, 1.0_dp, 0.4_dp, 0.5_dp, 1.0_dp, 0.6_dp, &
                             1.0_dp], ok)
        call checks%check(.not. ok .and. f%n == 0, 'layout: diagonal block incomplete')
        ! a block row that is not a pair (rows 3 and 4 of column 1, only row 4 of column 2)
        call pair_ldl_build(f, 4, [0, 1, 2, 3], [0, 4, 6, 8, 9], &
                            [0, 1, 2, 3, 1, 3, 2, 3, 3], &
                            [1.0_dp, 0.1_dp, 0.2_dp, 0.3_dp, 1.0_dp, 0.5_dp, 1.0_dp, 0.6_dp, &
                             1.0_dp], ok)
        call checks%check(.not. ok .and. f%n == 0, 'layout: half a block')
    end subroutine test_pair_layout_checked

    !> A matrix given as its values on another matrix's pattern (ls_factor, ls_solve,
    !> ls_solve_many and chol_factor with `val`; the other's values differ, so reading
    !> them would show): the same backend, factor and solutions, bit for bit, as the
    !> matrix with its own values; for the direct kind (CHOLMOD by pairs and simplicial,
    !> UMFPACK for an indefinite and a non-symmetric matrix), CG (node pairs and single
    !> dofs: the block copy, the products, the solves on the right-hand sides' supports)
    !> and 'auto'.
    subroutine test_values_on_pattern()
        character(len=*), parameter :: kinds(3) = [character(len=6) :: 'direct', 'cg', 'auto']
        character(len=*), parameter :: mats(4) = [character(len=12) :: 'pairs', 'spd', &
                                                  'indefinite', 'nonsymmetric']
        type(csc_t) :: a, other
        type(factor_t) :: f1, f2
        type(cholmod_t) :: c1, c2
        real(dp), allocatable :: val(:), b(:, :), x1(:, :), x2(:, :)
        integer :: ik, im, stat1, stat2, n, j
        character(len=40) :: what
        do im = 1, size(mats)
            call seed(20 + im)
            select case (im)
            case (1)
                call pair_matrix(150, a)
            case (2)
                call sym_matrix(300, 1.0_dp, 1.0_dp, a)
            case (3)
                call sym_matrix(300, 1.0_dp, 1.0_dp, a, indefinite=.true.)
            case default
                call sym_matrix(300, 1.0_dp, 1.0_dp, a)
                call perturb_off_diagonal(a)
            end select
            n = a%n
            allocate (val, source=a%val)
            other = a
            other%val = 3.0_dp * a%val + 1.0_dp        ! the pattern's own values: not read
            allocate (b(n, 20), x1(n, 20), x2(n, 20))
            b = 0.0_dp
            call random_number(b(:, 1:3))
            do j = 4, 20                               ! columns of the identity (CG: supports)
                b(1 + mod(7 * j, n), j) = 1.0_dp
            end do
            do ik = 1, size(kinds)
                what = trim(mats(im))//' '//trim(kinds(ik))
                call ls_configure(f1, trim(kinds(ik)), 2, 1.0e-12_dp, 500)
                call ls_configure(f2, trim(kinds(ik)), 2, 1.0e-12_dp, 500)
                call ls_factor(f1, a, stat1)
                call ls_factor(f2, other, stat2, val=val)
                call checks%check(stat1 == STAT_OK .and. stat2 == STAT_OK .and. &
                                  f1%backend == f2%backend .and. (f1%fell_back .eqv. f2%fell_back), &
                                  trim(what)//': the same backend')
                if (im == 1 .and. ik == 1) call checks%check(f2%backend == BACKEND_CHOLMOD, &
                                                             trim(what)//': CHOLMOD')
                if (im >= 3 .and. ik == 1) call checks%check(f2%backend == BACKEND_UMFPACK, &
                                                             trim(what)//': UMFPACK')
                if (im <= 2 .and. ik == 2) call checks%check(f2%backend == BACKEND_PCG, &
                                                             trim(what)//': CG')
                call ls_solve(f1, a, b(:, 1), x1(:, 1), stat1)
                call ls_solve(f2, other, b(:, 1), x2(:, 1), stat2, val=val)
                call checks%check(stat1 == STAT_OK .and. stat2 == STAT_OK .and. &
                                  all(x1(:, 1) == x2(:, 1)), trim(what)//': ls_solve bit for bit')
                call ls_solve_many(f1, a, b, x1, stat1)
                call ls_solve_many(f2, other, b, x2, stat2, val=val)
                call checks%check(stat1 == STAT_OK .and. stat2 == STAT_OK .and. all(x1 == x2), &
                                  trim(what)//': ls_solve_many bit for bit')
                call ls_free(f1)
                call ls_free(f2)
            end do
            if (im <= 2) then
                call chol_factor(c1, a, stat1)
                call chol_factor(c2, other, stat2, val=val)
                call chol_solve(c1, b(:, 1), x1(:, 1), stat1)
                call chol_solve(c2, b(:, 1), x2(:, 1), stat2)
                call checks%check(stat1 == STAT_OK .and. stat2 == STAT_OK .and. &
                                  c1%factor_nnz == c2%factor_nnz .and. all(x1(:, 1) == x2(:, 1)), &
                                  trim(mats(im))//': chol_factor with val bit for bit')
                call chol_free(c1)
                call chol_free(c2)
            end if
            call ls_factor(f2, other, stat2, val=val(1:a%nnz - 1))
            call checks%check(stat2 == STAT_BAD_INPUT, trim(mats(im))//': too few values refused')
            call ls_free(f2)
            deallocate (val, b, x1, x2)
        end do
    end subroutine test_values_on_pattern
end program test_cholmod
