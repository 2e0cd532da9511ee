!> Jacobi-preconditioned conjugate gradients for symmetric positive definite csc_t
!> matrices (the iterative kind of module linear_solver).
!>
!> A solve starts from x = 0, or from a guess the caller passes in x, and stops when the
!> residual |b - A x| is at most rtol |b|: the recurrence's residual first, then the
!> residual formed by a product with A (the recurrence drifts from it by round-off; the
!> iterations go on until the formed one passes too). Nothing is kept from one solve to
!> the next: the result depends only on A, b and the guess, so a run restarted from a
!> checkpoint (whose state gives the same guess) repeats the same numbers.
!>
!> A right-hand side with few nonzeros (a column of the identity, as in the contact
!> correction's J0^{-1} P^T) is solved on its support only: after k iterations x, r and
!> p are zero outside the k-th neighbourhood (in the graph of A) of the support of b,
!> so the products and sums run over that growing set of dofs, not over all n. This is
!> the same iteration (zeros add nothing) in another summation order.
!>
!> A curvature p^T A p <= 0 proves A is not positive definite: the solve stops with
!> STAT_NUMERIC and sets `indefinite` (the caller may factorize directly instead).
module pcg
    use kinds, only: dp, i8
    use vector_ops, only: dot, lane_sum, LANES
    use text, only: int_text, real_text
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, raise
    use sparse, only: csc_t, csc_find, csc_matvec_t
    implicit none
    private

    !> A support-restricted solve switches to the full vectors once its set of dofs
    !> exceeds this fraction of n (the indexed loops then cost more than they save).
    real(dp), parameter :: SPARSE_FRACTION = 0.25_dp

    !> Preconditioner, tolerances, work vectors and counters of one matrix.
    type, public :: pcg_t
        integer :: n = 0                        !! size (0: not set up)
        real(dp) :: rtol = 1.0e-12_dp           !! relative residual tolerance
        integer :: max_iter = 500               !! iteration limit of one solve
        real(dp), allocatable :: dinv(:)        !! (n) inverse diagonal (Jacobi)
        real(dp), allocatable :: r(:), z(:), p(:), q(:)  !! (n) work vectors
        integer, allocatable :: idx(:)          !! (n) support-restricted solve: its dofs
        logical, allocatable :: on(:)           !! (n) whether a dof is in idx
        logical :: indefinite = .false.         !! the last solve met p^T A p <= 0
        integer(i8) :: solves = 0               !! solves done
        integer(i8) :: iterations = 0           !! iterations over all solves
        integer :: max_its = 0                  !! most iterations of one solve
        integer :: last_its = 0                 !! iterations of the last solve
    end type pcg_t

    public :: pcg_setup, pcg_solve, pcg_solve_many, pcg_free

contains

    !> Set up for the symmetric matrix a: inverse diagonal and work vectors. A diagonal
    !> entry that is not positive (or missing) means a is not positive definite:
    !> STAT_NUMERIC, `indefinite` set.
    subroutine pcg_setup(p, a, rtol, max_iter, stat, errmsg)
        type(pcg_t), intent(inout) :: p                     !! solver (replaced)
        type(csc_t), intent(in) :: a                        !! symmetric matrix
        real(dp), intent(in) :: rtol                        !! relative residual tolerance (> 0)
        integer, intent(in) :: max_iter                     !! iteration limit (> 0)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: j, k
        real(dp) :: d
        call pcg_free(p)
        p%indefinite = .false.
        if (a%n < 1 .or. .not. (rtol > 0.0_dp) .or. max_iter < 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'pcg_setup: empty matrix or bad tolerances')
            return
        end if
        allocate (p%dinv(a%n))
        do j = 1, a%n
            k = csc_find(a, j, j)
            d = 0.0_dp
            if (k > 0) d = a%val(k)
            if (.not. (d > 0.0_dp .and. d <= huge(d))) then
                p%indefinite = .true.
                deallocate (p%dinv)
                call raise(stat, errmsg, STAT_NUMERIC, 'pcg_setup: diagonal entry '// &
                           int_text(j)//' is not positive: the matrix is not positive definite')
                return
            end if
            p%dinv(j) = 1.0_dp / d
        end do
        allocate (p%r(a%n), p%z(a%n), p%p(a%n), p%q(a%n), p%idx(a%n), p%on(a%n))
        p%q = 0.0_dp
        p%p = 0.0_dp
        p%on = .false.
        p%n = a%n
        p%rtol = rtol
        p%max_iter = max_iter
        stat = STAT_OK
    end subroutine pcg_setup

    !> Solve A x = b from x = 0, or from the x given when `guess` is true. STAT_NUMERIC
    !> when the residual does not reach rtol |b| within max_iter iterations, or A shows
    !> it is not positive definite.
    subroutine pcg_solve(p, a, b, x, stat, errmsg, guess)
        type(pcg_t), intent(inout) :: p                     !! solver set up for a
        type(csc_t), intent(in) :: a                        !! the matrix
        real(dp), intent(in), contiguous :: b(:)            !! right-hand side (n)
        real(dp), intent(inout), contiguous :: x(:)         !! guess (with `guess`), solution (n)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        logical, intent(in), optional :: guess              !! x holds a first guess
        real(dp) :: bnorm, tol2, rz, rz_new, pq, alpha, beta, rr
        integer :: it, n
        logical :: warm
        n = p%n
        if (n < 1 .or. a%n /= n .or. size(b) < n .or. size(x) < n) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'pcg_solve: not set up for this matrix')
            return
        end if
        stat = STAT_OK
        p%indefinite = .false.
        warm = .false.
        if (present(guess)) warm = guess
        if (.not. warm) x(1:n) = 0.0_dp
        bnorm = sqrt(dot(b(1:n), b(1:n)))
        p%solves = p%solves + 1
        p%last_its = 0
        if (bnorm == 0.0_dp) then
            x(1:n) = 0.0_dp
            return
        end if
        tol2 = (p%rtol * bnorm)**2
        if (warm) then
            call csc_matvec_t(a, x, p%q)
            p%r = b(1:n) - p%q
        else
            p%r = b(1:n)
        end if
        p%z = p%dinv * p%r
        p%p = p%z
        rz = dot(p%r, p%z)
        rr = dot(p%r, p%r)
        it = 0
        do
            if (rr <= tol2) then
                ! the formed residual must pass too (the recurrence drifts by round-off)
                call csc_matvec_t(a, x, p%q)
                p%r = b(1:n) - p%q
                rr = dot(p%r, p%r)
                if (rr <= tol2) exit
                p%z = p%dinv * p%r
                p%p = p%z
                rz = dot(p%r, p%z)
            end if
            if (.not. (rr == rr) .or. it >= p%max_iter) then
                call fail(sqrt(rr) / bnorm)
                return
            end if
            call csc_matvec_t(a, p%p, p%q)
            pq = dot(p%p, p%q)
            if (.not. (pq > 0.0_dp)) then
                call indefinite(pq)
                return
            end if
            alpha = rz / pq
            call cg_update(n, alpha, p%p, p%q, p%dinv, x, p%r, p%z, rz_new, rr)
            beta = rz_new / rz
            rz = rz_new
            p%p = p%z + beta * p%p
            it = it + 1
        end do
        call tally(it)
    contains
        !> Non-convergence: STAT_NUMERIC with the residual reached.
        subroutine fail(rel)
            real(dp), intent(in) :: rel    !! relative residual reached
            call tally(it)
            call raise(stat, errmsg, STAT_NUMERIC, 'conjugate gradients did not converge: '// &
                       'relative residual '//real_text(rel, 3)//' after '//int_text(it)// &
                       ' iterations (&solver cg_rtol = '//real_text(p%rtol, 3)// &
                       ', cg_max_iter = '//int_text(p%max_iter)//')')
        end subroutine fail
        !> p^T A p <= 0: not positive definite.
        subroutine indefinite(curv)
            real(dp), intent(in) :: curv   !! p^T A p
            call tally(it)
            p%indefinite = .true.
            call raise(stat, errmsg, STAT_NUMERIC, 'conjugate gradients met the curvature '// &
                       real_text(curv, 3)//' <= 0: the matrix is not positive definite')
        end subroutine indefinite
        !> Iteration counters.
        subroutine tally(its)
            integer, intent(in) :: its     !! iterations of this solve
            p%last_its = its
            p%iterations = p%iterations + its
            p%max_its = max(p%max_its, its)
        end subroutine tally
    end subroutine pcg_solve

    !> Solve A X = B column after column; a column with few nonzeros is solved on its
    !> growing support (module header). Errors as pcg_solve's.
    subroutine pcg_solve_many(p, a, b, x, stat, errmsg)
        type(pcg_t), intent(inout) :: p                     !! solver set up for a
        type(csc_t), intent(in) :: a                        !! the matrix
        real(dp), intent(in) :: b(:, :)                     !! right-hand sides (n, m)
        real(dp), intent(out) :: x(:, :)                    !! solutions (n, m)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: j, nb
        stat = STAT_OK
        if (p%n < 1 .or. a%n /= p%n .or. size(b, 1) < p%n .or. size(x, 1) < p%n .or. &
            size(b, 2) /= size(x, 2)) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'pcg_solve_many: not set up for this matrix')
            return
        end if
        do j = 1, size(b, 2)
            nb = count(b(1:p%n, j) /= 0.0_dp)
            if (nb <= SPARSE_FRACTION * p%n) then
                call solve_support(p, a, b(:, j), x(:, j), stat, errmsg)
            else
                call pcg_solve(p, a, b(1:p%n, j), x(1:p%n, j), stat, errmsg)
            end if
            if (stat /= STAT_OK) return
        end do
    end subroutine pcg_solve_many

    !> pcg_solve on the support of b and its neighbourhoods (see the module header):
    !> p%idx(1:na) lists the dofs where x, r or p may be nonzero; the product q = A p
    !> scatters the columns of that set (A symmetric: column j holds row j) and adds the
    !> rows it reaches. Falls back to pcg_solve when the set grows past SPARSE_FRACTION n.
    subroutine solve_support(p, a, b, x, stat, errmsg)
        type(pcg_t), intent(inout) :: p                     !! solver
        type(csc_t), intent(in) :: a                        !! the matrix
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(out) :: x(:)                       !! solution (n)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: bnorm, tol2, rz, rz_new, pq, alpha, beta, rr, pj
        integer :: it, n, na, i, j, k, l, na0
        logical :: formed
        n = p%n
        stat = STAT_OK
        p%indefinite = .false.
        x(1:n) = 0.0_dp
        na = 0
        do i = 1, n
            if (b(i) /= 0.0_dp) call add(i)
        end do
        p%solves = p%solves + 1
        p%last_its = 0
        if (na == 0) return
        bnorm = 0.0_dp
        do l = 1, na
            bnorm = bnorm + b(p%idx(l))**2
        end do
        bnorm = sqrt(bnorm)
        tol2 = (p%rtol * bnorm)**2
        rz = 0.0_dp
        do l = 1, na
            i = p%idx(l)
            p%r(i) = b(i)
            p%z(i) = p%dinv(i) * b(i)
            p%p(i) = p%z(i)
            rz = rz + p%r(i) * p%z(i)
        end do
        it = 0
        formed = .false.
        do
            rr = 0.0_dp
            do l = 1, na
                rr = rr + p%r(p%idx(l))**2
            end do
            if (rr <= tol2) then
                ! the formed residual b - A x: A x on the set (x is zero outside it)
                call product(x)
                rr = 0.0_dp
                rz = 0.0_dp
                do l = 1, na
                    i = p%idx(l)
                    p%r(i) = b(i) - p%q(i)
                    p%z(i) = p%dinv(i) * p%r(i)
                    p%p(i) = p%z(i)
                    rr = rr + p%r(i)**2
                    rz = rz + p%r(i) * p%z(i)
                end do
                if (rr <= tol2) exit
            end if
            if (.not. (rr == rr) .or. it >= p%max_iter) then
                call clear()
                call count_its()
                call raise(stat, errmsg, STAT_NUMERIC, 'conjugate gradients did not converge: '// &
                           'relative residual '//real_text(sqrt(rr) / bnorm, 3)//' after '// &
                           int_text(it)//' iterations (&solver cg_rtol = '//real_text(p%rtol, 3)// &
                           ', cg_max_iter = '//int_text(p%max_iter)//')')
                return
            end if
            if (na > SPARSE_FRACTION * n) then
                ! the set covers much of the mesh: go on with full vectors from here
                call full_rest()
                return
            end if
            call product(p%p)
            pq = 0.0_dp
            do l = 1, na
                pq = pq + p%p(p%idx(l)) * p%q(p%idx(l))
            end do
            if (.not. (pq > 0.0_dp)) then
                call clear()
                call count_its()
                p%indefinite = .true.
                call raise(stat, errmsg, STAT_NUMERIC, 'conjugate gradients met the curvature '// &
                           real_text(pq, 3)//' <= 0: the matrix is not positive definite')
                return
            end if
            alpha = rz / pq
            rz_new = 0.0_dp
            do l = 1, na
                i = p%idx(l)
                x(i) = x(i) + alpha * p%p(i)
                p%r(i) = p%r(i) - alpha * p%q(i)
                p%z(i) = p%dinv(i) * p%r(i)
                rz_new = rz_new + p%r(i) * p%z(i)
            end do
            beta = rz_new / rz
            rz = rz_new
            do l = 1, na
                i = p%idx(l)
                p%p(i) = p%z(i) + beta * p%p(i)
            end do
            it = it + 1
        end do
        call clear()
        call count_its()
    contains
        !> Put dof i in the set.
        subroutine add(ii)
            integer, intent(in) :: ii
            na = na + 1
            p%idx(na) = ii
            p%on(ii) = .true.
            p%r(ii) = 0.0_dp; p%z(ii) = 0.0_dp; p%p(ii) = 0.0_dp; p%q(ii) = 0.0_dp
        end subroutine add
        !> q = A v for v zero outside the set; the rows reached join the set.
        subroutine product(v)
            real(dp), intent(in) :: v(:)
            do l = 1, na
                p%q(p%idx(l)) = 0.0_dp
            end do
            na0 = na
            do l = 1, na0
                j = p%idx(l)
                pj = v(j)
                if (pj == 0.0_dp) cycle
                do k = a%colptr(j) + 1, a%colptr(j + 1)
                    i = a%rowind(k) + 1
                    if (.not. p%on(i)) call add(i)
                    p%q(i) = p%q(i) + a%val(k) * pj
                end do
            end do
        end subroutine product
        !> Zero the work vectors on the set and empty it.
        subroutine clear()
            do l = 1, na
                i = p%idx(l)
                p%on(i) = .false.
                p%r(i) = 0.0_dp; p%z(i) = 0.0_dp; p%p(i) = 0.0_dp; p%q(i) = 0.0_dp
            end do
            na = 0
        end subroutine clear
        !> Iteration counters.
        subroutine count_its()
            p%last_its = it
            p%iterations = p%iterations + it
            p%max_its = max(p%max_its, it)
        end subroutine count_its
        !> The rest of the solve with full vectors, from the current x (one more solve
        !> of the correction: A e = b - A x, x <- x + e).
        subroutine full_rest()
            real(dp), allocatable :: res(:), e(:)
            integer :: it0
            it0 = it
            call clear()
            allocate (res(n), e(n))
            call csc_matvec_t(a, x, res)
            res = b(1:n) - res
            ! the correction's tolerance keeps |b - A x| <= rtol |b| overall
            block
                real(dp) :: rtol0, rn
                rtol0 = p%rtol
                rn = sqrt(dot(res, res))
                p%solves = p%solves - 1    ! counted as one solve with this one
                if (rn > 0.0_dp) then
                    p%rtol = min(1.0_dp, rtol0 * bnorm / rn)
                    call pcg_solve(p, a, res, e, stat, errmsg)
                    p%rtol = rtol0
                    x(1:n) = x(1:n) + e
                    ! counters: the two parts are one solve
                    p%iterations = p%iterations + it0
                    p%last_its = p%last_its + it0
                    p%max_its = max(p%max_its, p%last_its)
                else
                    p%solves = p%solves + 1
                    p%last_its = it0
                    p%iterations = p%iterations + it0
                    p%max_its = max(p%max_its, it0)
                end if
            end block
        end subroutine full_rest
    end subroutine solve_support

    !> One pass of a CG iteration: x += alpha p, r -= alpha q, z = dinv r, and the sums
    !> r.z and r.r, each kept in LANES partial sums (module vector_ops) so that the loop
    !> vectorizes.
    pure subroutine cg_update(n, alpha, p, q, dinv, x, r, z, rz, rr)
        integer, intent(in) :: n                            !! size
        real(dp), intent(in) :: alpha                       !! step
        real(dp), intent(in) :: p(n), q(n), dinv(n)         !! direction, A p, inverse diagonal
        real(dp), intent(inout) :: x(n), r(n)               !! iterate, residual
        real(dp), intent(out) :: z(n)                       !! preconditioned residual
        real(dp), intent(out) :: rz, rr                     !! r.z and r.r
        real(dp) :: az(LANES), ar(LANES)
        integer :: i, j, nb
        nb = n - mod(n, LANES)
        az = 0.0_dp
        ar = 0.0_dp
        do i = 1, nb, LANES
            do j = i, i + LANES - 1
                x(j) = x(j) + alpha * p(j)
                r(j) = r(j) - alpha * q(j)
                z(j) = dinv(j) * r(j)
                az(j - i + 1) = az(j - i + 1) + r(j) * z(j)
                ar(j - i + 1) = ar(j - i + 1) + r(j) * r(j)
            end do
        end do
        do j = nb + 1, n
            x(j) = x(j) + alpha * p(j)
            r(j) = r(j) - alpha * q(j)
            z(j) = dinv(j) * r(j)
            az(1) = az(1) + r(j) * z(j)
            ar(1) = ar(1) + r(j) * r(j)
        end do
        rz = lane_sum(az)
        rr = lane_sum(ar)
    end subroutine cg_update

    !> Release the work vectors and the preconditioner (counters kept).
    subroutine pcg_free(p)
        type(pcg_t), intent(inout) :: p      !! solver
        if (allocated(p%dinv)) deallocate (p%dinv)
        if (allocated(p%r)) deallocate (p%r, p%z, p%p, p%q)
        if (allocated(p%idx)) deallocate (p%idx, p%on)
        p%n = 0
    end subroutine pcg_free
end module pcg
