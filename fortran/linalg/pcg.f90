!> Preconditioned conjugate gradients by node blocks, for symmetric positive definite
!> csc_t matrices (the iterative kind of module linear_solver).
!>
!> Node blocks. pcg_setup finds the nodes in the pattern of A: a run of consecutive dofs
!> whose columns have the same rows (the free dofs of one node, whose element blocks are
!> full) is split into groups of the block size bs, the commonest run length (2 in 2D, 3
!> in 3D, 1 on a bar). With bs = 2 or 3 the products with A run on a node-block copy of
!> A (module sparse's block2_t / block3_t kernels, the direct path's: the same sums as the
!> CSC product, about twice as fast). Preconditioners: one right-hand side (pcg_solve)
!> with bs >= 2, symmetric Gauss-Seidel over the node blocks (ssor_solve); several
!> (pcg_solve_many), the inverse of each group's diagonal block (block Jacobi); bs = 1,
!> the scalar Jacobi. Grouping dofs that are not one node would still give the same
!> products and SPD preconditioners.
!>
!> A solve starts from x = 0, or from a guess the caller passes in x (dropped for x = 0
!> when its residual is larger than b: such a guess costs iterations), and stops when the
!> residual |b - A x| is at most rtol |b|: the recurrence's residual first, then the
!> residual formed by a product with A (the recurrence drifts from it by round-off; the
!> iterations go on until the formed one passes too). Nothing is kept from one solve to
!> the next: the result depends only on A, b and the guess, so a run restarted from a
!> checkpoint (whose state gives the same guess) repeats the same numbers.
!>
!> Several right-hand sides (pcg_solve_many) are solved PCG_COLUMNS at a time: one CG
!> recurrence per column (its own step lengths, its own stopping test, frozen once it
!> passes), but one pass over A for the products of all of them, vectors stored column
!> by column of a (k, n) block so that a matrix entry is applied to k values at once.
!> Right-hand sides with few nonzeros (columns of the identity, as in the contact
!> correction's J0^{-1} P^T) are solved on their support: after i iterations x, r and p
!> are zero outside the i-th neighbourhood (in the graph of A) of the union of the
!> supports, so the products and sums run over that growing set of node groups, kept
!> compact; once it passes SPARSE_FRACTION n the iteration goes on over all dofs (the
!> same iteration, the state moved over). The set changes only the summation order.
!>
!> A curvature p^T A p <= 0, or a diagonal block that is not positive definite, proves A
!> is not positive definite: STAT_NUMERIC with `indefinite` set (the caller may factorize
!> directly instead).
module pcg
    use kinds, only: dp, i8
    use vector_ops, only: dot, lane_sum, LANES
    use text, only: int_text, real_text
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, raise
    use sparse, only: csc_t, csc_find, csc_matvec_t, csc_matvec_t_values, block2_t, &
                      block2_from_csc, block2_matvec, block3_t, block3_from_csc, block3_matvec
    implicit none
    private

    !> A support-restricted solve goes over to the full vectors once its set of dofs
    !> exceeds this fraction of n (the indexed loops then cost more than they save).
    real(dp), parameter :: SPARSE_FRACTION = 0.25_dp

    !> Right-hand sides solved together by pcg_solve_many (the contact correction's
    !> groups of columns have 16).
    integer, parameter, public :: PCG_COLUMNS = 16

    !> Preconditioner, block copy of A, tolerances, work vectors and counters of one matrix.
    type, public :: pcg_t
        integer :: n = 0                        !! size (0: not set up)
        real(dp) :: rtol = 1.0e-12_dp           !! relative residual tolerance
        integer :: max_iter = 500               !! iteration limit of one solve
        integer :: bs = 1                       !! node block size: 1, 2 or 3
        integer :: ng = 0                       !! node groups (of 1 to bs dofs)
        integer, allocatable :: first(:)        !! (ng + 1) first dof of each group
        integer, allocatable :: gof(:)          !! (n) group of each dof
        real(dp), allocatable :: binv(:, :)     !! (bs*bs, ng) inverse diagonal blocks, by columns
        type(block2_t) :: b2                    !! A by 2x2 blocks (bs = 2)
        type(block3_t) :: b3                    !! A by 3x3 blocks (bs = 3)
        integer, allocatable :: kd(:)           !! (ng) the block of each row's diagonal (bs >= 2)
        real(dp), allocatable :: dg(:), sd(:)   !! (n) diagonal of A and its square root (bs >= 2)
        real(dp), allocatable :: r(:), z(:), p(:), q(:)  !! (n) work vectors
        integer, allocatable :: loc(:)          !! (n) position of a dof in a solve's set (0: none)
        logical :: indefinite = .false.         !! the last solve met p^T A p <= 0
        integer(i8) :: solves = 0               !! solves done (one per right-hand side)
        integer(i8) :: iterations = 0           !! iterations over all solves
        integer :: max_its = 0                  !! most iterations of one solve
        integer :: last_its = 0                 !! iterations of the last solve (most of a group)
    end type pcg_t

    public :: pcg_setup, pcg_solve, pcg_solve_many, pcg_free, pcg_product, pcg_product_many

contains

    !> Set up for the symmetric matrix a: node groups, block copy, inverse diagonal blocks
    !> and work vectors. A diagonal block that is not positive definite (a diagonal entry
    !> <= 0 or missing among them) means a is not: STAT_NUMERIC, `indefinite` set.
    !> With `val`, the matrix is the one with a's pattern and those values (a%val is not
    !> read; pass the same val to the solves).
    pure subroutine pcg_setup(p, a, rtol, max_iter, stat, errmsg, val)
        type(pcg_t), intent(inout) :: p                     !! solver (replaced)
        type(csc_t), intent(in) :: a                        !! symmetric matrix
        real(dp), intent(in) :: rtol                        !! relative residual tolerance (> 0)
        integer, intent(in) :: max_iter                     !! iteration limit (> 0)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern
        call pcg_free(p)
        p%indefinite = .false.
        if (a%n < 1 .or. .not. (rtol > 0.0_dp) .or. max_iter < 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'pcg_setup: empty matrix or bad tolerances')
            return
        end if
        if (present(val)) then
            call setup_values(p, a, val, rtol, max_iter, stat, errmsg)
        else
            call setup_values(p, a, a%val, rtol, max_iter, stat, errmsg)
        end if
    end subroutine pcg_setup

    !> pcg_setup (its arguments checked) for the matrix with a's pattern and the values v.
    pure subroutine setup_values(p, a, v, rtol, max_iter, stat, errmsg)
        type(pcg_t), intent(inout) :: p                     !! solver (freed)
        type(csc_t), intent(in) :: a                        !! the pattern
        real(dp), intent(in) :: v(:)                        !! (a%nnz) the values
        real(dp), intent(in) :: rtol                        !! relative residual tolerance (> 0)
        integer, intent(in) :: max_iter                     !! iteration limit (> 0)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: g, i0, sz, r, c, k
        real(dp) :: blk(3, 3), inv(3, 3)
        logical :: ok
        if (size(v) < a%nnz) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'pcg_setup: fewer values than entries')
            return
        end if
        call node_groups(a, p%bs, p%ng, p%first)
        allocate (p%gof(a%n), p%binv(p%bs * p%bs, p%ng))
        p%binv = 0.0_dp
        do g = 1, p%ng
            i0 = p%first(g)
            sz = p%first(g + 1) - i0
            p%gof(i0:i0 + sz - 1) = g
            blk = 0.0_dp
            do c = 1, sz
                do r = 1, sz
                    k = csc_find(a, i0 + r - 1, i0 + c - 1)
                    if (k > 0) blk(r, c) = v(k)
                end do
            end do
            call spd_inverse(sz, blk, inv, ok)
            if (.not. ok) then
                p%indefinite = .true.
                call pcg_free(p)
                if (sz == 1) then
                    call raise(stat, errmsg, STAT_NUMERIC, 'pcg_setup: diagonal entry '// &
                               int_text(i0)//' is not positive: the matrix is not positive definite')
                else
                    call raise(stat, errmsg, STAT_NUMERIC, 'pcg_setup: the diagonal block of dofs '// &
                               int_text(i0)//' to '//int_text(i0 + sz - 1)// &
                               ' is not positive definite: neither is the matrix')
                end if
                return
            end if
            do c = 1, sz
                do r = 1, sz
                    p%binv(r + p%bs * (c - 1), g) = inv(r, c)
                end do
            end do
        end do
        stat = STAT_OK
        if (p%bs == 2) call block2_from_csc(a, p%first, p%b2, stat, errmsg, v)
        if (p%bs == 3) call block3_from_csc(a, p%first, p%b3, stat, errmsg, v)
        if (stat /= STAT_OK) then
            call pcg_free(p)
            return
        end if
        p%n = a%n
        if (p%bs >= 2) call ssor_setup(p)
        allocate (p%r(a%n), p%z(a%n), p%p(a%n), p%q(a%n), p%loc(a%n))
        p%q = 0.0_dp
        p%p = 0.0_dp
        p%loc = 0
        p%rtol = rtol
        p%max_iter = max_iter
    end subroutine setup_values

    !> The node groups of a's pattern (module header): maximal runs of consecutive
    !> columns with the same rows, bs = the commonest run length (1 to 3; ties to the
    !> larger), each run split into groups of bs dofs (its last group may be smaller).
    pure subroutine node_groups(a, bs, ng, first)
        type(csc_t), intent(in) :: a                        !! symmetric matrix
        integer, intent(out) :: bs                          !! block size
        integer, intent(out) :: ng                          !! groups
        integer, allocatable, intent(out) :: first(:)       !! (ng + 1) group starts
        integer, allocatable :: run(:)
        integer :: j, nr, l, cnt(3), k
        allocate (run(a%n + 1))
        nr = 1
        run(1) = 1
        do j = 2, a%n
            if (.not. same_rows(j - 1, j)) then
                nr = nr + 1
                run(nr) = j
            end if
        end do
        run(nr + 1) = a%n + 1
        cnt = 0
        do k = 1, nr
            l = min(run(k + 1) - run(k), 3)
            cnt(l) = cnt(l) + 1
        end do
        bs = 3
        if (cnt(2) > cnt(bs)) bs = 2
        if (cnt(1) > cnt(bs)) bs = 1
        allocate (first(a%n + 1))
        ng = 0
        do k = 1, nr
            do j = run(k), run(k + 1) - 1, bs
                ng = ng + 1
                first(ng) = j
            end do
        end do
        first(ng + 1) = a%n + 1
        first = first(1:ng + 1)
    contains
        !> Columns i and j store the same rows.
        pure logical function same_rows(i, jj)
            integer, intent(in) :: i, jj   !! the two columns
            integer :: ki, kj, len
            ki = a%colptr(i)
            kj = a%colptr(jj)
            len = a%colptr(i + 1) - ki
            same_rows = len == a%colptr(jj + 1) - kj
            if (same_rows) same_rows = all(a%rowind(ki + 1:ki + len) == a%rowind(kj + 1:kj + len))
        end function same_rows
    end subroutine node_groups

    !> The inverse of the leading sz x sz block of blk (sz = 1 to 3), if that block is
    !> positive definite (its Cholesky pivots positive and finite).
    pure subroutine spd_inverse(sz, blk, inv, ok)
        integer, intent(in) :: sz                  !! block size
        real(dp), intent(in) :: blk(3, 3)          !! block (leading sz x sz used)
        real(dp), intent(out) :: inv(3, 3)         !! inverse (leading sz x sz; zero elsewhere)
        logical, intent(out) :: ok                 !! the block is positive definite
        real(dp) :: l(3, 3), li(3, 3), d
        integer :: i, j, k
        inv = 0.0_dp
        l = 0.0_dp
        ok = .false.
        ! Cholesky blk = L L^T
        do j = 1, sz
            d = blk(j, j) - sum(l(j, 1:j - 1)**2)
            if (.not. (d > 0.0_dp .and. d <= huge(d))) return
            l(j, j) = sqrt(d)
            do i = j + 1, sz
                l(i, j) = (blk(i, j) - sum(l(i, 1:j - 1) * l(j, 1:j - 1))) / l(j, j)
            end do
        end do
        ! L^{-1} (lower triangular), then inv = L^{-T} L^{-1}
        li = 0.0_dp
        do j = 1, sz
            li(j, j) = 1.0_dp / l(j, j)
            do i = j + 1, sz
                li(i, j) = -sum(l(i, j:i - 1) * li(j:i - 1, j)) / l(i, i)
            end do
        end do
        do j = 1, sz
            do i = 1, sz
                inv(i, j) = 0.0_dp
                do k = max(i, j), sz
                    inv(i, j) = inv(i, j) + li(k, i) * li(k, j)
                end do
            end do
        end do
        ok = .true.
    end subroutine spd_inverse

    !> y = A x with p's block copy of a (csc_matvec_t when bs = 1): bitwise equal to
    !> csc_matvec_t (module sparse). x and y have n entries and must not alias. `val`:
    !> as given to pcg_setup.
    pure subroutine pcg_product(p, a, x, y, val)
        type(pcg_t), intent(in) :: p                        !! solver set up for a
        type(csc_t), intent(in) :: a                        !! the matrix
        real(dp), intent(in), contiguous :: x(:)            !! (n)
        real(dp), intent(out), contiguous :: y(:)           !! (n)
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern
        select case (p%bs)
        case (2)
            call block2_matvec(p%b2, x, y)
        case (3)
            call block3_matvec(p%b3, x, y)
        case default
            if (present(val)) then
                call csc_matvec_t_values(a, val, x, y)
            else
                call csc_matvec_t(a, x, y)
            end if
        end select
    end subroutine pcg_product

    !> Y = A X for the k columns of X stored as rows of v (k, n): one pass over p's block
    !> copy of a for all of them; each column's sums in the order of pcg_product.
    pure subroutine pcg_product_many(p, a, k, v, y, val)
        type(pcg_t), intent(in) :: p                        !! solver set up for a
        type(csc_t), intent(in) :: a                        !! the matrix
        integer, intent(in) :: k                            !! columns
        real(dp), intent(in) :: v(k, p%n)                   !! vectors, one a row
        real(dp), intent(out) :: y(k, p%n)                  !! products, one a row
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern
        select case (p%bs)
        case (2)
            call many2(k, p%n, p%ng, size(p%b2%col1), p%b2%row_ptr, p%b2%col1, p%b2%col2, &
                       p%b2%pairs, p%first, p%b2%val, v, y)
        case (3)
            call many3(k, p%n, p%ng, size(p%b3%col1), p%b3%row_ptr, p%b3%col1, p%b3%col2, &
                       p%b3%col3, p%b3%triples, p%first, p%b3%val, v, y)
        case default
            if (present(val)) then
                call many1(k, p%n, a%nnz, a%colptr, a%rowind, val, v, y)
            else
                call many1(k, p%n, a%nnz, a%colptr, a%rowind, a%val, v, y)
            end if
        end select
    end subroutine pcg_product_many

    !> pcg_product_many on a CSC matrix (symmetric: column j holds row j).
    pure subroutine many1(k, n, nnz, colptr, rowind, val, v, y)
        integer, intent(in) :: k, n, nnz                   !! columns, size, entries
        integer, intent(in) :: colptr(n + 1), rowind(nnz)  !! 0-based pattern
        real(dp), intent(in) :: val(nnz)                   !! values
        real(dp), intent(in) :: v(k, n)                    !! vectors
        real(dp), intent(out) :: y(k, n)                   !! products
        integer :: j, e
        real(dp) :: acc(k)
        do j = 1, n
            acc = 0.0_dp
            do e = colptr(j) + 1, colptr(j + 1)
                acc = acc + val(e) * v(:, rowind(e) + 1)
            end do
            y(:, j) = acc
        end do
    end subroutine many1

    !> pcg_product_many on a block2_t's arrays (a block's rows summed as block2_matvec does).
    pure subroutine many2(k, n, ng, nb, row_ptr, col1, col2, pairs, first, val, v, y)
        integer, intent(in) :: k, n, ng, nb                !! columns, size, groups, blocks
        integer, intent(in) :: row_ptr(ng + 1)             !! block range of each row group
        integer, intent(in) :: col1(nb)                    !! first column dof of each block
        integer, intent(in) :: col2(*)                     !! (nb) second one (not read when pairs)
        logical, intent(in) :: pairs                       !! every group a pair: col1 + 1
        integer, intent(in) :: first(ng + 1)               !! first dof of each group
        real(dp), intent(in) :: val(4, nb)                 !! blocks
        real(dp), intent(in) :: v(k, n)                    !! vectors
        real(dp), intent(out) :: y(k, n)                   !! products
        integer :: g, e, c1, c2, i
        real(dp) :: s1(k), s2(k)
        do g = 1, ng
            s1 = 0.0_dp
            s2 = 0.0_dp
            do e = row_ptr(g), row_ptr(g + 1) - 1
                c1 = col1(e)
                if (pairs) then
                    c2 = c1 + 1
                else
                    c2 = col2(e)
                end if
                s1 = s1 + val(1, e) * v(:, c1) + val(3, e) * v(:, c2)
                s2 = s2 + val(2, e) * v(:, c1) + val(4, e) * v(:, c2)
            end do
            i = first(g)
            y(:, i) = s1
            if (first(g + 1) - i == 2) y(:, i + 1) = s2
        end do
    end subroutine many2

    !> pcg_product_many on a block3_t's arrays (a block's rows summed as block3_matvec does).
    pure subroutine many3(k, n, ng, nb, row_ptr, col1, col2, col3, triples, first, val, v, y)
        integer, intent(in) :: k, n, ng, nb                !! columns, size, groups, blocks
        integer, intent(in) :: row_ptr(ng + 1)             !! block range of each row group
        integer, intent(in) :: col1(nb)                    !! first column dof of each block
        integer, intent(in) :: col2(*), col3(*)            !! (nb) second, third (not read when triples)
        logical, intent(in) :: triples                     !! every group a triple: col1 + 1, col1 + 2
        integer, intent(in) :: first(ng + 1)               !! first dof of each group
        real(dp), intent(in) :: val(9, nb + 1)             !! blocks (and the zero block)
        real(dp), intent(in) :: v(k, n)                    !! vectors
        real(dp), intent(out) :: y(k, n)                   !! products
        integer :: g, e, c1, c2, c3, i, sz
        real(dp) :: s1(k), s2(k), s3(k)
        do g = 1, ng
            s1 = 0.0_dp
            s2 = 0.0_dp
            s3 = 0.0_dp
            do e = row_ptr(g), row_ptr(g + 1) - 1
                c1 = col1(e)
                if (triples) then
                    c2 = c1 + 1
                    c3 = c1 + 2
                else
                    c2 = col2(e)
                    c3 = col3(e)
                end if
                s1 = s1 + val(1, e) * v(:, c1) + val(4, e) * v(:, c2) + val(7, e) * v(:, c3)
                s2 = s2 + val(2, e) * v(:, c1) + val(5, e) * v(:, c2) + val(8, e) * v(:, c3)
                s3 = s3 + val(3, e) * v(:, c1) + val(6, e) * v(:, c2) + val(9, e) * v(:, c3)
            end do
            i = first(g)
            sz = first(g + 1) - i
            y(:, i) = s1
            if (sz >= 2) y(:, i + 1) = s2
            if (sz == 3) y(:, i + 2) = s3
        end do
    end subroutine many3

    !> Solve A x = b from x = 0, or from the x given when `guess` is true and
    !> |b - A x| <= |b| (from x = 0 otherwise). STAT_NUMERIC
    !> when the residual does not reach rtol |b| within max_iter iterations, or A shows
    !> it is not positive definite. `val`: as given to pcg_setup.
    subroutine pcg_solve(p, a, b, x, stat, errmsg, guess, val)
        type(pcg_t), intent(inout) :: p                     !! solver set up for a
        type(csc_t), intent(in) :: a                        !! the matrix
        real(dp), intent(in), contiguous :: b(:)            !! right-hand side (n)
        real(dp), intent(inout), contiguous :: x(:)         !! guess (with `guess`), solution (n)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        logical, intent(in), optional :: guess              !! x holds a first guess
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern
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
        if (p%bs >= 2) then
            call ssor_solve(p, a, b, x, warm, stat, errmsg)
            return
        end if
        bnorm = sqrt(dot(b(1:n), b(1:n)))
        p%solves = p%solves + 1
        p%last_its = 0
        if (bnorm == 0.0_dp) then
            x(1:n) = 0.0_dp
            return
        end if
        tol2 = (p%rtol * bnorm)**2
        if (warm) then
            call pcg_product(p, a, x, p%q, val)
            p%r = b(1:n) - p%q
            ! a guess farther from b than x = 0 is (|b - A x| > |b|) is dropped
            if (dot(p%r, p%r) > bnorm**2) warm = .false.
        end if
        if (.not. warm) then
            x(1:n) = 0.0_dp
            p%r = b(1:n)
        end if
        call precondition()
        p%p = p%z
        rz = dot(p%r, p%z)
        rr = dot(p%r, p%r)
        it = 0
        do
            if (rr <= tol2) then
                ! the formed residual must pass too (the recurrence drifts by round-off)
                call pcg_product(p, a, x, p%q, val)
                p%r = b(1:n) - p%q
                rr = dot(p%r, p%r)
                if (rr <= tol2) exit
                call precondition()
                p%p = p%z
                rz = dot(p%r, p%z)
            end if
            if (.not. (rr == rr) .or. it >= p%max_iter) then
                call fail(sqrt(rr) / bnorm)
                return
            end if
            call pcg_product(p, a, p%p, p%q, val)
            pq = dot(p%p, p%q)
            if (.not. (pq > 0.0_dp)) then
                call indefinite(pq)
                return
            end if
            alpha = rz / pq
            if (p%bs == 1) then
                call cg_update(n, alpha, p%p, p%q, p%binv, x, p%r, p%z, rz_new, rr)
            else if (p%bs == 2 .and. p%b2%pairs) then
                call cg_update2(n, alpha, p%p, p%q, p%binv, x, p%r, p%z, rz_new, rr)
            else
                call cg_update_groups(n, p%ng, p%bs, p%first, alpha, p%p, p%q, p%binv, x, p%r, &
                                      p%z, rz_new, rr)
            end if
            beta = rz_new / rz
            rz = rz_new
            call direction(n, beta, p%z, p%p)
            it = it + 1
        end do
        call tally(p, it)
    contains
        !> z = (block Jacobi) r.
        subroutine precondition()
            integer :: ss, g
            do g = 1, p%ng
                ss = p%first(g)
                call block_apply(p%bs, p%first(g + 1) - ss, p%binv(:, g), 1, p%r(ss:), p%z(ss:))
            end do
        end subroutine precondition
        !> Non-convergence: STAT_NUMERIC with the residual reached.
        subroutine fail(rel)
            real(dp), intent(in) :: rel    !! relative residual reached
            call tally(p, it)
            call raise(stat, errmsg, STAT_NUMERIC, 'conjugate gradients did not converge: '// &
                       'relative residual '//real_text(rel, 3)//' after '//int_text(it)// &
                       ' iterations (&solver cg_rtol = '//real_text(p%rtol, 3)// &
                       ', cg_max_iter = '//int_text(p%max_iter)//')')
        end subroutine fail
        !> p^T A p <= 0: not positive definite.
        subroutine indefinite(curv)
            real(dp), intent(in) :: curv   !! p^T A p
            call tally(p, it)
            p%indefinite = .true.
            call raise(stat, errmsg, STAT_NUMERIC, 'conjugate gradients met the curvature '// &
                       real_text(curv, 3)//' <= 0: the matrix is not positive definite')
        end subroutine indefinite
    end subroutine pcg_solve

    !> The iteration counters after one solve of its iterations.
    pure subroutine tally(p, its)
        type(pcg_t), intent(inout) :: p                     !! solver
        integer, intent(in) :: its                          !! iterations of this solve
        p%last_its = its
        p%iterations = p%iterations + its
        p%max_its = max(p%max_its, its)
    end subroutine tally

    !> The diagonal's blocks in the block copy and D, D^{1/2} for ssor_solve.
    pure subroutine ssor_setup(p)
        type(pcg_t), intent(inout) :: p                     !! solver (bs >= 2, block copy built)
        integer :: g, k, i0, sz, r
        allocate (p%kd(p%ng), p%dg(p%n), p%sd(p%n))
        p%kd = 0
        do g = 1, p%ng
            i0 = p%first(g)
            sz = p%first(g + 1) - i0
            if (p%bs == 2) then
                do k = p%b2%row_ptr(g), p%b2%row_ptr(g + 1) - 1
                    if (p%b2%col1(k) == i0) p%kd(g) = k
                end do
                do r = 0, sz - 1
                    p%dg(i0 + r) = p%b2%val(1 + 3 * r, p%kd(g))
                end do
            else
                do k = p%b3%row_ptr(g), p%b3%row_ptr(g + 1) - 1
                    if (p%b3%col1(k) == i0) p%kd(g) = k
                end do
                do r = 0, sz - 1
                    p%dg(i0 + r) = p%b3%val(1 + 4 * r, p%kd(g))
                end do
            end if
        end do
        p%sd = sqrt(p%dg)
    end subroutine ssor_setup

    !> pcg_solve with the symmetric Gauss-Seidel (SSOR, omega = 1) preconditioner
    !> M = F D^{-1} F^T, F = D + L (D the diagonal, L the strict lower triangle of A),
    !> by Eisenstat's trick: CG on A^ = E^{-1} A E^{-T}, E = F D^{-1/2}, whose product
    !> A^ v = D^{1/2} (t + F^{-1}(D^{1/2} v - D t)), t = F^{-T} D^{1/2} v, costs one
    !> backward and one forward sweep over the node blocks: about one product with A.
    !> x = E^{-T} x^ is kept as it goes (x += alpha t). On the mass-dominated J0 the
    !> condition number drops from about 4 (2D) and 5 (3D) with Jacobi to 1.2 and 1.5,
    !> so a solve takes about half the iterations at the same cost each. The recurrence
    !> gives r^ = E^{-1} r, not r: it is stopped when |r^| has fallen by the factor
    !> |r| needs (with the ratio |r^| / |r| of the last formed residual), then the formed
    !> residual b - A x decides, as in pcg_solve.
    subroutine ssor_solve(p, a, b, x, warm, stat, errmsg)
        type(pcg_t), intent(inout) :: p                     !! solver set up for a (bs >= 2)
        type(csc_t), intent(in) :: a                        !! the matrix
        real(dp), intent(in), contiguous :: b(:)            !! right-hand side (n)
        real(dp), intent(inout), contiguous :: x(:)         !! guess (with warm), solution (n)
        logical, intent(in) :: warm                         !! x holds a first guess
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: bnorm, tol2, htol2, rh, rh_new, rr, pq, alpha, beta
        integer :: it, n
        n = p%n
        stat = STAT_OK
        p%solves = p%solves + 1
        p%last_its = 0
        if (.not. warm) x(1:n) = 0.0_dp
        bnorm = sqrt(dot(b(1:n), b(1:n)))
        if (bnorm == 0.0_dp) then
            x(1:n) = 0.0_dp
            return
        end if
        tol2 = (p%rtol * bnorm)**2
        if (warm) then
            call pcg_product(p, a, x, p%q)
            p%q = b(1:n) - p%q
            rr = dot(p%q, p%q)
            ! a guess farther from b than x = 0 is (|b - A x| > |b|) is dropped
            if (rr > bnorm**2) then
                x(1:n) = 0.0_dp
                p%q = b(1:n)
                rr = dot(p%q, p%q)
            end if
        else
            p%q = b(1:n)
            rr = dot(p%q, p%q)
        end if
        call restart()
        it = 0
        do
            if (rh <= htol2) then
                ! the formed residual must pass
                call pcg_product(p, a, x, p%q)
                p%q = b(1:n) - p%q
                rr = dot(p%q, p%q)
                if (rr <= tol2) exit
                call restart()
            end if
            if (.not. (rh == rh) .or. it >= p%max_iter) then
                ! rr is the residual formed at the start or the last restart: form the one
                ! of the x reached, which the message reports
                if (it > 0) then
                    call pcg_product(p, a, x, p%q)
                    p%q = b(1:n) - p%q
                    rr = dot(p%q, p%q)
                end if
                call tally(p, it)
                call raise(stat, errmsg, STAT_NUMERIC, 'conjugate gradients did not converge: '// &
                           'relative residual '//real_text(sqrt(rr) / bnorm, 3)//' after '// &
                           int_text(it)//' iterations (&solver cg_rtol = '//real_text(p%rtol, 3)// &
                           ', cg_max_iter = '//int_text(p%max_iter)//')')
                return
            end if
            ! q = A^ p: t = F^{-T} D^{1/2} p in z, then q = D^{1/2} (t + F^{-1}(D^{1/2} p - D t))
            p%z = p%sd * p%p
            call sweep(.false., p%z)
            p%q = p%sd * p%p - p%dg * p%z
            call sweep(.true., p%q)
            p%q = p%sd * (p%z + p%q)
            pq = dot(p%p, p%q)
            if (.not. (pq > 0.0_dp)) then
                call tally(p, it)
                p%indefinite = .true.
                call raise(stat, errmsg, STAT_NUMERIC, 'conjugate gradients met the curvature '// &
                           real_text(pq, 3)//' <= 0: the matrix is not positive definite')
                return
            end if
            alpha = rh / pq
            call ssor_update(n, alpha, p%z, p%q, x, p%r, rh_new)
            beta = rh_new / rh
            rh = rh_new
            call direction(n, beta, p%r, p%p)
            it = it + 1
        end do
        call tally(p, it)
    contains
        !> r^ = D^{1/2} F^{-1} q from the residual q (|q|^2 = rr), p^ = r^, and the
        !> recurrence's target: |r^| reduced by the factor |r| needs.
        subroutine restart()
            p%r = p%q
            call sweep(.true., p%r)
            p%r = p%sd * p%r
            p%p = p%r
            rh = dot(p%r, p%r)
            htol2 = tol2 * (rh / rr)
        end subroutine restart
        !> y = F^{-1} y (forward) or F^{-T} y (backward), in place.
        pure subroutine sweep(forward, y)
            logical, intent(in) :: forward                  !! forward (lower) sweep
            real(dp), intent(inout) :: y(:)                 !! right-hand side, solution
            if (p%bs == 2) then
                call sweep2(forward, p%n, p%ng, size(p%b2%col1), p%b2%row_ptr, p%b2%col1, &
                            p%b2%col2, p%b2%pairs, p%first, p%kd, p%b2%val, y)
            else
                call sweep3(forward, p%n, p%ng, size(p%b3%col1), p%b3%row_ptr, p%b3%col1, &
                            p%b3%col2, p%b3%col3, p%b3%triples, p%first, p%kd, p%b3%val, y)
            end if
        end subroutine sweep
    end subroutine ssor_solve

    !> x += alpha t, r -= alpha q, rh = r.r (LANES partial sums).
    pure subroutine ssor_update(n, alpha, t, q, x, r, rh)
        integer, intent(in) :: n                            !! size
        real(dp), intent(in) :: alpha                       !! step
        real(dp), intent(in) :: t(n), q(n)                  !! E^{-T} p, A^ p
        real(dp), intent(inout) :: x(n), r(n)               !! iterate, transformed residual
        real(dp), intent(out) :: rh                         !! r.r
        real(dp) :: ar(LANES)
        integer :: i, j, nb
        nb = n - mod(n, LANES)
        ar = 0.0_dp
        do i = 1, nb, LANES
            do j = i, i + LANES - 1
                x(j) = x(j) + alpha * t(j)
                r(j) = r(j) - alpha * q(j)
                ar(j - i + 1) = ar(j - i + 1) + r(j) * r(j)
            end do
        end do
        do j = nb + 1, n
            x(j) = x(j) + alpha * t(j)
            r(j) = r(j) - alpha * q(j)
            ar(1) = ar(1) + r(j) * r(j)
        end do
        rh = lane_sum(ar)
    end subroutine ssor_update

    !> y = F^{-1} y (forward) or F^{-T} y (backward) in place, F = D + L of a block2_t
    !> matrix: a row group's blocks left (forward) or right (backward) of its diagonal
    !> block kd(g), then the diagonal block's triangle.
    pure subroutine sweep2(forward, n, ng, nb, row_ptr, col1, col2, pairs, first, kd, val, y)
        logical, intent(in) :: forward                      !! forward (lower) sweep
        integer, intent(in) :: n, ng, nb                    !! size, groups, blocks
        integer, intent(in) :: row_ptr(ng + 1), col1(nb), first(ng + 1), kd(ng)
            !! row_ptr: each group's blocks (CSR); col1: each block's first column;
            !! first: each group's first dof; kd: each group's diagonal block
        integer, intent(in) :: col2(*)                      !! (nb) not read when pairs
        logical, intent(in) :: pairs                        !! every group a pair: col1 + 1
        real(dp), intent(in) :: val(4, nb)                  !! blocks
        real(dp), intent(inout) :: y(n)                     !! right-hand side, solution
        integer :: g, k, i0, sz, d, c2
        real(dp) :: s(2)
        if (forward) then
            do g = 1, ng
                i0 = first(g)
                sz = first(g + 1) - i0
                s(1) = y(i0)
                s(2) = y(i0 + sz - 1)
                do k = row_ptr(g), row_ptr(g + 1) - 1
                    if (col1(k) < i0) then
                        if (pairs) then
                            c2 = col1(k) + 1
                        else
                            c2 = col2(k)
                        end if
                        s = s - val(1:2, k) * y(col1(k)) - val(3:4, k) * y(c2)
                    end if
                end do
                d = kd(g)
                y(i0) = s(1) / val(1, d)
                if (sz == 2) y(i0 + 1) = (s(2) - val(2, d) * y(i0)) / val(4, d)
            end do
        else
            do g = ng, 1, -1
                i0 = first(g)
                sz = first(g + 1) - i0
                s(1) = y(i0)
                s(2) = y(i0 + sz - 1)
                do k = row_ptr(g), row_ptr(g + 1) - 1
                    if (col1(k) > i0) then
                        if (pairs) then
                            c2 = col1(k) + 1
                        else
                            c2 = col2(k)
                        end if
                        s = s - val(1:2, k) * y(col1(k)) - val(3:4, k) * y(c2)
                    end if
                end do
                d = kd(g)
                if (sz == 2) then
                    y(i0 + 1) = s(2) / val(4, d)
                    y(i0) = (s(1) - val(3, d) * y(i0 + 1)) / val(1, d)
                else
                    y(i0) = s(1) / val(1, d)
                end if
            end do
        end if
    end subroutine sweep2

    !> sweep2 for a block3_t matrix.
    pure subroutine sweep3(forward, n, ng, nb, row_ptr, col1, col2, col3, triples, first, kd, val, y)
        logical, intent(in) :: forward                      !! forward (lower) sweep
        integer, intent(in) :: n, ng, nb                    !! size, groups, blocks
        integer, intent(in) :: row_ptr(ng + 1), col1(nb), first(ng + 1), kd(ng)
            !! row_ptr: each group's blocks (CSR); col1: each block's first column;
            !! first: each group's first dof; kd: each group's diagonal block
        integer, intent(in) :: col2(*), col3(*)             !! (nb) not read when triples
        logical, intent(in) :: triples                      !! every group a triple: col1 + 1, + 2
        real(dp), intent(in) :: val(9, nb + 1)              !! blocks (and the zero block)
        real(dp), intent(inout) :: y(n)                     !! right-hand side, solution
        integer :: g, k, i0, sz, d, c2, c3
        real(dp) :: s(3)
        if (forward) then
            do g = 1, ng
                i0 = first(g)
                sz = first(g + 1) - i0
                s = 0.0_dp
                s(1:sz) = y(i0:i0 + sz - 1)
                do k = row_ptr(g), row_ptr(g + 1) - 1
                    if (col1(k) < i0) then
                        if (triples) then
                            c2 = col1(k) + 1
                            c3 = col1(k) + 2
                        else
                            c2 = col2(k)
                            c3 = col3(k)
                        end if
                        s = s - val(1:3, k) * y(col1(k)) - val(4:6, k) * y(c2) - val(7:9, k) * y(c3)
                    end if
                end do
                d = kd(g)
                y(i0) = s(1) / val(1, d)
                if (sz >= 2) y(i0 + 1) = (s(2) - val(2, d) * y(i0)) / val(5, d)
                if (sz == 3) y(i0 + 2) = (s(3) - val(3, d) * y(i0) - val(6, d) * y(i0 + 1)) / val(9, d)
            end do
        else
            do g = ng, 1, -1
                i0 = first(g)
                sz = first(g + 1) - i0
                s = 0.0_dp
                s(1:sz) = y(i0:i0 + sz - 1)
                do k = row_ptr(g), row_ptr(g + 1) - 1
                    if (col1(k) > i0) then
                        if (triples) then
                            c2 = col1(k) + 1
                            c3 = col1(k) + 2
                        else
                            c2 = col2(k)
                            c3 = col3(k)
                        end if
                        s = s - val(1:3, k) * y(col1(k)) - val(4:6, k) * y(c2) - val(7:9, k) * y(c3)
                    end if
                end do
                d = kd(g)
                select case (sz)
                case (3)
                    y(i0 + 2) = s(3) / val(9, d)
                    y(i0 + 1) = (s(2) - val(8, d) * y(i0 + 2)) / val(5, d)
                    y(i0) = (s(1) - val(4, d) * y(i0 + 1) - val(7, d) * y(i0 + 2)) / val(1, d)
                case (2)
                    y(i0 + 1) = s(2) / val(5, d)
                    y(i0) = (s(1) - val(4, d) * y(i0 + 1)) / val(1, d)
                case default
                    y(i0) = s(1) / val(1, d)
                end select
            end do
        end if
    end subroutine sweep3

    !> z(:, 1:sz) = B^{-1} r(:, 1:sz) for one group of sz dofs, k values a dof (k = 1: a
    !> single vector), binv the group's inverse block (bs x bs by columns).
    pure subroutine block_apply(bs, sz, binv, k, r, z)
        integer, intent(in) :: bs, sz, k                   !! block size, group size, columns
        real(dp), intent(in) :: binv(bs * bs)              !! inverse block
        real(dp), intent(in) :: r(k, *)                    !! residual of the group's dofs
        real(dp), intent(out) :: z(k, *)                   !! preconditioned residual
        integer :: i, c
        do i = 1, sz
            z(:, i) = binv(i) * r(:, 1)
            do c = 2, sz
                z(:, i) = z(:, i) + binv(i + bs * (c - 1)) * r(:, c)
            end do
        end do
    end subroutine block_apply

    !> p = z + beta p.
    pure subroutine direction(n, beta, z, p)
        integer, intent(in) :: n                            !! size
        real(dp), intent(in) :: beta                        !! coefficient
        real(dp), intent(in) :: z(n)                        !! preconditioned residual
        real(dp), intent(inout) :: p(n)                     !! direction
        p = z + beta * p
    end subroutine direction

    !> One pass of a CG iteration, scalar Jacobi (bs = 1, dinv the inverse diagonal):
    !> x += alpha p, r -= alpha q, z = dinv r, and the sums r.z and r.r, each kept in
    !> LANES partial sums (module vector_ops) so that the loop vectorizes.
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

    !> cg_update with 2x2 block Jacobi when every group is a pair: binv(:, g) is the
    !> inverse block of dofs 2g-1, 2g.
    pure subroutine cg_update2(n, alpha, p, q, binv, x, r, z, rz, rr)
        integer, intent(in) :: n                            !! size (even)
        real(dp), intent(in) :: alpha                       !! step
        real(dp), intent(in) :: p(n), q(n)                  !! direction, A p
        real(dp), intent(in) :: binv(4, n / 2)              !! inverse blocks
        real(dp), intent(inout) :: x(n), r(n)               !! iterate, residual
        real(dp), intent(out) :: z(n)                       !! preconditioned residual
        real(dp), intent(out) :: rz, rr                     !! r.z and r.r
        real(dp) :: az(2), ar(2), r1, r2
        integer :: g, i
        az = 0.0_dp
        ar = 0.0_dp
        do g = 1, n / 2
            i = 2 * g - 1
            x(i:i + 1) = x(i:i + 1) + alpha * p(i:i + 1)
            r(i:i + 1) = r(i:i + 1) - alpha * q(i:i + 1)
            r1 = r(i)
            r2 = r(i + 1)
            z(i:i + 1) = binv(1:2, g) * r1 + binv(3:4, g) * r2
            az = az + r(i:i + 1) * z(i:i + 1)
            ar = ar + r(i:i + 1) * r(i:i + 1)
        end do
        rz = az(1) + az(2)
        rr = ar(1) + ar(2)
    end subroutine cg_update2

    !> cg_update with block Jacobi on groups of 1 to bs dofs (bs = 2 or 3; a group of
    !> three through one 3-vector step).
    pure subroutine cg_update_groups(n, ng, bs, first, alpha, p, q, binv, x, r, z, rz, rr)
        integer, intent(in) :: n, ng, bs                    !! size, groups, block size
        integer, intent(in) :: first(ng + 1)                !! group starts
        real(dp), intent(in) :: alpha                       !! step
        real(dp), intent(in) :: p(n), q(n)                  !! direction, A p
        real(dp), intent(in) :: binv(bs * bs, ng)           !! inverse blocks
        real(dp), intent(inout) :: x(n), r(n)               !! iterate, residual
        real(dp), intent(out) :: z(n)                       !! preconditioned residual
        real(dp), intent(out) :: rz, rr                     !! r.z and r.r
        real(dp) :: az(3), ar(3), s(3)
        integer :: g, i, sz
        az = 0.0_dp
        ar = 0.0_dp
        do g = 1, ng
            i = first(g)
            sz = first(g + 1) - i
            if (sz == 3) then
                x(i:i + 2) = x(i:i + 2) + alpha * p(i:i + 2)
                r(i:i + 2) = r(i:i + 2) - alpha * q(i:i + 2)
                s = r(i:i + 2)
                z(i:i + 2) = binv(1:3, g) * s(1) + binv(4:6, g) * s(2) + binv(7:9, g) * s(3)
                az = az + s * z(i:i + 2)
                ar = ar + s * s
            else
                x(i:i + sz - 1) = x(i:i + sz - 1) + alpha * p(i:i + sz - 1)
                r(i:i + sz - 1) = r(i:i + sz - 1) - alpha * q(i:i + sz - 1)
                call block_apply(bs, sz, binv(:, g), 1, r(i:), z(i:))
                az(1:sz) = az(1:sz) + r(i:i + sz - 1) * z(i:i + sz - 1)
                ar(1:sz) = ar(1:sz) + r(i:i + sz - 1)**2
            end if
        end do
        rz = az(1) + az(2) + az(3)
        rr = ar(1) + ar(2) + ar(3)
    end subroutine cg_update_groups

    !> Solve A X = B, PCG_COLUMNS columns at a time (module header). Errors as pcg_solve's.
    !> `val`: as given to pcg_setup.
    subroutine pcg_solve_many(p, a, b, x, stat, errmsg, val)
        type(pcg_t), intent(inout) :: p                     !! solver set up for a
        type(csc_t), intent(in) :: a                        !! the matrix
        real(dp), intent(in) :: b(:, :)                     !! right-hand sides (n, m)
        real(dp), intent(out) :: x(:, :)                    !! solutions (n, m)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern
        integer :: j, j2
        stat = STAT_OK
        if (p%n < 1 .or. a%n /= p%n .or. size(b, 1) < p%n .or. size(x, 1) < p%n .or. &
            size(b, 2) /= size(x, 2)) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'pcg_solve_many: not set up for this matrix')
            return
        end if
        do j = 1, size(b, 2), PCG_COLUMNS
            j2 = min(j + PCG_COLUMNS - 1, size(b, 2))
            if (present(val)) then
                call solve_columns(p, a, val, b(:, j:j2), x(:, j:j2), stat, errmsg)
            else
                call solve_columns(p, a, a%val, b(:, j:j2), x(:, j:j2), stat, errmsg)
            end if
            if (stat /= STAT_OK) return
        end do
    end subroutine pcg_solve_many

    !> The k columns of b solved together from x = 0 (module header): one recurrence a
    !> column, one product for all. The set of dofs where x, r or p may be nonzero is a
    !> list of node groups, stored compactly (a dof's values at column loc(dof) of the
    !> (k, cap) work blocks, a group's dofs side by side); the product scatters the set's
    !> columns of A (symmetric: column j holds row j) after adding the groups they reach.
    !> Past SPARSE_FRACTION n the set becomes every dof, in place (loc = identity), and the
    !> products run on the block copy. A column whose recurrence's residual passes waits
    !> (frozen); when none is left iterating, one product forms the waiting columns'
    !> residuals: those that pass are done, the others start again from their formed
    !> residual, as pcg_solve does.
    subroutine solve_columns(p, a, val, b, x, stat, errmsg)
        type(pcg_t), intent(inout) :: p                     !! solver
        type(csc_t), intent(in) :: a                        !! the matrix's pattern
        real(dp), intent(in) :: val(:)                      !! (a%nnz) its values
        real(dp), intent(in) :: b(:, :)                     !! right-hand sides (n, k)
        real(dp), intent(out) :: x(:, :)                    !! solutions (n, k)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer, parameter :: ACTIVE = 0, WAITING = 1, DONE = 2
        real(dp), allocatable :: xs(:, :), rs(:, :), ps(:, :), qs(:, :)
        integer, allocatable :: sd(:), sg(:)
        real(dp) :: bnorm(size(b, 2)), tol2(size(b, 2)), rz(size(b, 2)), rr(size(b, 2))
        real(dp) :: pq(size(b, 2)), alpha(size(b, 2)), beta(size(b, 2)), keep(size(b, 2))
        real(dp) :: rzn(size(b, 2)), rrn(size(b, 2))
        integer :: state(size(b, 2)), its(size(b, 2))
        integer :: k, n, nd, nsg, cap, c, l, i, j
        logical :: full
        n = p%n
        k = size(b, 2)
        stat = STAT_OK
        p%indefinite = .false.
        full = .false.
        nd = 0
        nsg = 0
        cap = 0
        its = 0
        allocate (sd(0), sg(0), xs(k, 0), rs(k, 0), ps(k, 0), qs(k, 0))
        ! the set: the groups of the right-hand sides' nonzeros
        do i = 1, n
            if (p%loc(i) == 0 .and. any(b(i, :) /= 0.0_dp)) call add_group(p%gof(i))
        end do
        do c = 1, k
            bnorm(c) = 0.0_dp
            do l = 1, nd
                bnorm(c) = bnorm(c) + b(sd(l), c)**2
                rs(c, l) = b(sd(l), c)
            end do
            bnorm(c) = sqrt(bnorm(c))
        end do
        tol2 = (p%rtol * bnorm)**2
        state = merge(DONE, ACTIVE, bnorm == 0.0_dp)
        keep = 1.0_dp
        beta = 0.0_dp
        alpha = 0.0_dp
        call sweep()
        rz = rzn
        rr = rrn
        call new_directions()
        do
            where (state == ACTIVE .and. rr <= tol2) state = WAITING
            if (.not. any(state == ACTIVE)) then
                if (.not. any(state == WAITING)) exit
                call check()
                if (.not. any(state == ACTIVE)) exit
            end if
            do c = 1, k
                if (state(c) /= ACTIVE) cycle
                if (.not. (rr(c) == rr(c)) .or. its(c) >= p%max_iter) then
                    call finish()
                    call raise(stat, errmsg, STAT_NUMERIC, 'conjugate gradients did not '// &
                               'converge: relative residual '//real_text(sqrt(rr(c)) / bnorm(c), 3)// &
                               ' after '//int_text(its(c))//' iterations (&solver cg_rtol = '// &
                               real_text(p%rtol, 3)//', cg_max_iter = '//int_text(p%max_iter)//')')
                    return
                end if
            end do
            if (.not. full .and. nd > SPARSE_FRACTION * n) call go_full()
            call product(.false.)
            pq = 0.0_dp
            do l = 1, nd
                pq = pq + ps(:, l) * qs(:, l)
            end do
            do c = 1, k
                if (state(c) == ACTIVE .and. .not. (pq(c) > 0.0_dp)) then
                    call finish()
                    p%indefinite = .true.
                    call raise(stat, errmsg, STAT_NUMERIC, 'conjugate gradients met the '// &
                               'curvature '//real_text(pq(c), 3)//' <= 0: the matrix is not '// &
                               'positive definite')
                    return
                end if
            end do
            where (state == ACTIVE)
                alpha = rz / pq
            elsewhere
                alpha = 0.0_dp
            end where
            call sweep()
            where (state == ACTIVE)
                beta = rzn / rz
                rz = rzn
                rr = rrn
                keep = 1.0_dp
                its = its + 1
            elsewhere
                beta = 1.0_dp
                keep = 0.0_dp
            end where
            call new_directions()
        end do
        call finish()
    contains
        !> Add group g to the set (zero values), growing the work blocks when full.
        subroutine add_group(g)
            integer, intent(in) :: g                        !! group
            integer :: i0, sz, m
            i0 = p%first(g)
            sz = p%first(g + 1) - i0
            if (nd + sz > cap) then
                cap = max(2 * cap, nd + sz, 64)
                call grow(xs)
                call grow(rs)
                call grow(ps)
                call grow(qs)
                call grow_int(sd)
            end if
            if (nsg + 1 > size(sg)) call grow_int(sg)
            nsg = nsg + 1
            sg(nsg) = g
            do m = 0, sz - 1
                nd = nd + 1
                sd(nd) = i0 + m
                p%loc(i0 + m) = nd
                xs(:, nd) = 0.0_dp
                rs(:, nd) = 0.0_dp
                ps(:, nd) = 0.0_dp
                qs(:, nd) = 0.0_dp
            end do
        end subroutine add_group
        !> A work block with cap columns, its first nd kept.
        pure subroutine grow(v)
            real(dp), allocatable, intent(inout) :: v(:, :)   !! work block
            real(dp), allocatable :: t(:, :)
            allocate (t(k, cap))
            t(:, 1:nd) = v(:, 1:nd)
            call move_alloc(t, v)
        end subroutine grow
        !> An index list with room for cap entries, its entries kept.
        pure subroutine grow_int(v)
            integer, allocatable, intent(inout) :: v(:)   !! index list
            integer, allocatable :: t(:)
            allocate (t(max(cap, 2 * size(v), 16)))
            t(1:size(v)) = v
            call move_alloc(t, v)
        end subroutine grow_int
        !> The set becomes every dof, its values moved in place: loc = identity.
        subroutine go_full()
            integer :: g, ll
            call to_full(xs)
            call to_full(rs)
            call to_full(ps)
            deallocate (qs)
            allocate (qs(k, n))
            do ll = 1, nd
                p%loc(sd(ll)) = 0
            end do
            deallocate (sd, sg)
            allocate (sd(n), sg(p%ng))
            sd = [(ll, ll = 1, n)]
            sg = [(g, g = 1, p%ng)]
            nd = n
            nsg = p%ng
            cap = n
            full = .true.
        end subroutine go_full
        !> A work block of the set as a (k, n) block of every dof.
        pure subroutine to_full(v)
            real(dp), allocatable, intent(inout) :: v(:, :)   !! work block
            real(dp), allocatable :: t(:, :)
            integer :: ll
            allocate (t(k, n))
            t = 0.0_dp
            do ll = 1, nd
                t(:, sd(ll)) = v(:, ll)
            end do
            call move_alloc(t, v)
        end subroutine to_full
        !> qs = A ps (or A xs with `of_x`) on the set, after adding the groups it reaches.
        subroutine product(of_x)
            logical, intent(in) :: of_x                     !! multiply xs, not ps
            integer :: nd0, e
            if (full) then
                if (of_x) then
                    call pcg_product_many(p, a, k, xs, qs, val)
                else
                    call pcg_product_many(p, a, k, ps, qs, val)
                end if
                return
            end if
            nd0 = nd
            do l = 1, nd0
                j = sd(l)
                if (of_x) then
                    if (all(xs(:, l) == 0.0_dp)) cycle
                else
                    if (all(ps(:, l) == 0.0_dp)) cycle
                end if
                do e = a%colptr(j) + 1, a%colptr(j + 1)
                    i = a%rowind(e) + 1
                    if (p%loc(i) == 0) call add_group(p%gof(i))
                end do
            end do
            if (of_x) then
                call scatter(k, n, nd0, nd, sd, p%loc, a%nnz, a%colptr, a%rowind, val, xs, qs)
            else
                call scatter(k, n, nd0, nd, sd, p%loc, a%nnz, a%colptr, a%rowind, val, ps, qs)
            end if
        end subroutine product
        !> xs += alpha ps, rs -= alpha qs over the set; rzn = r.z and rrn = r.r, z the
        !> block-Jacobi preconditioned residual.
        subroutine sweep()
            call update_many(k, nd, nsg, sg, p%loc, p%first, p%bs, p%binv, alpha, xs, rs, ps, qs, &
                             rzn, rrn, full)
        end subroutine sweep
        !> ps = keep z + beta ps over the set.
        subroutine new_directions()
            call directions_many(k, nd, nsg, sg, p%loc, p%first, p%bs, p%binv, keep, beta, rs, ps, &
                                 full)
        end subroutine new_directions
        !> The waiting columns' formed residuals b - A x: done if they pass, else restarted.
        subroutine check()
            call product(.true.)
            rrn = 0.0_dp
            do c = 1, k
                if (state(c) /= WAITING) cycle
                do l = 1, nd
                    rs(c, l) = b(sd(l), c) - qs(c, l)
                end do
                rrn(c) = sum(rs(c, 1:nd)**2)
            end do
            where (state == WAITING .and. rrn <= tol2) state = DONE
            ! the others start again from the formed residual: p = z
            where (state == WAITING)
                keep = 1.0_dp
                beta = 0.0_dp
            elsewhere
                keep = 0.0_dp
                beta = 1.0_dp
            end where
            alpha = 0.0_dp
            call sweep()
            where (state == WAITING)
                rz = rzn
                rr = rrn
            end where
            call new_directions()
            where (state == WAITING) state = ACTIVE
        end subroutine check
        !> x from the set, the set emptied, the counters.
        subroutine finish()
            integer :: cc, ll
            do cc = 1, k
                x(1:n, cc) = 0.0_dp
                do ll = 1, nd
                    x(sd(ll), cc) = xs(cc, ll)
                end do
            end do
            if (.not. full) then
                do ll = 1, nd
                    p%loc(sd(ll)) = 0
                end do
            end if
            p%solves = p%solves + k
            p%iterations = p%iterations + sum(int(its, i8))
            p%last_its = maxval(its)
            p%max_its = max(p%max_its, p%last_its)
        end subroutine finish
    end subroutine solve_columns

    !> q(:, loc(i)) += a_ij v(:, l) for the set's first nd0 dofs j = sd(l) (q zeroed on
    !> the nd dofs of the set first; every row reached is in the set).
    pure subroutine scatter(k, n, nd0, nd, sd, loc, nnz, colptr, rowind, val, v, q)
        integer, intent(in) :: k, n, nd0, nd, nnz           !! columns, size, set sizes, entries
        integer, intent(in) :: sd(nd), loc(n)               !! set dofs, their positions
        integer, intent(in) :: colptr(n + 1), rowind(nnz)   !! 0-based pattern
        real(dp), intent(in) :: val(nnz)                    !! values
        real(dp), intent(in) :: v(k, *)                     !! vectors on the set
        real(dp), intent(inout) :: q(k, *)                  !! products on the set
        integer :: l, j, e, li
        q(:, 1:nd) = 0.0_dp
        do l = 1, nd0
            j = sd(l)
            if (all(v(:, l) == 0.0_dp)) cycle
            do e = colptr(j) + 1, colptr(j + 1)
                li = loc(rowind(e) + 1)
                q(:, li) = q(:, li) + val(e) * v(:, l)
            end do
        end do
    end subroutine scatter

    !> The update sweep of solve_columns over the set's groups: x += alpha p, r -= alpha q,
    !> z = B^{-1} r by group, rz = r.z and rr = r.r per column. A group's dofs sit side by
    !> side from the position of its first dof (loc, or the dof itself when `full`).
    pure subroutine update_many(k, nd, nsg, sg, loc, first, bs, binv, alpha, x, r, p, q, rz, rr, full)
        integer, intent(in) :: k, nd, nsg, bs               !! columns, set dofs, set groups, block size
        integer, intent(in) :: sg(nsg), loc(*), first(*)    !! set groups, positions, group starts
        real(dp), intent(in) :: binv(bs * bs, *)            !! inverse blocks
        real(dp), intent(in) :: alpha(k)                    !! steps (0: column unchanged)
        real(dp), intent(inout) :: x(k, nd), r(k, nd)       !! iterates, residuals
        real(dp), intent(in) :: p(k, nd), q(k, nd)          !! directions, A p
        real(dp), intent(out) :: rz(k), rr(k)               !! r.z, r.r
        logical, intent(in) :: full                         !! positions are the dofs
        real(dp) :: z(k, 3)
        integer :: s, g, l0, sz, m
        rz = 0.0_dp
        rr = 0.0_dp
        do s = 1, nsg
            g = sg(s)
            l0 = first(g)
            if (.not. full) l0 = loc(l0)
            sz = first(g + 1) - first(g)
            do m = l0, l0 + sz - 1
                x(:, m) = x(:, m) + alpha * p(:, m)
                r(:, m) = r(:, m) - alpha * q(:, m)
            end do
            call block_apply(bs, sz, binv(:, g), k, r(:, l0:), z)
            do m = 1, sz
                rz = rz + r(:, l0 + m - 1) * z(:, m)
                rr = rr + r(:, l0 + m - 1)**2
            end do
        end do
    end subroutine update_many

    !> p = keep z + beta p over the set's groups, z = B^{-1} r (positions as update_many).
    pure subroutine directions_many(k, nd, nsg, sg, loc, first, bs, binv, keep, beta, r, p, full)
        integer, intent(in) :: k, nd, nsg, bs               !! columns, set dofs, set groups, block size
        integer, intent(in) :: sg(nsg), loc(*), first(*)    !! set groups, positions, group starts
        real(dp), intent(in) :: binv(bs * bs, *)            !! inverse blocks
        real(dp), intent(in) :: keep(k), beta(k)            !! coefficients
        real(dp), intent(in) :: r(k, nd)                    !! residuals
        real(dp), intent(inout) :: p(k, nd)                 !! directions
        logical, intent(in) :: full                         !! positions are the dofs
        real(dp) :: z(k, 3)
        integer :: s, g, l0, sz, m
        do s = 1, nsg
            g = sg(s)
            l0 = first(g)
            if (.not. full) l0 = loc(l0)
            sz = first(g + 1) - first(g)
            call block_apply(bs, sz, binv(:, g), k, r(:, l0:), z)
            do m = 1, sz
                p(:, l0 + m - 1) = keep * z(:, m) + beta * p(:, l0 + m - 1)
            end do
        end do
    end subroutine directions_many

    !> Release the work vectors, the block copy and the preconditioner (counters kept).
    pure subroutine pcg_free(p)
        type(pcg_t), intent(inout) :: p      !! solver
        type(block2_t) :: e2
        type(block3_t) :: e3
        if (allocated(p%first)) deallocate (p%first)
        if (allocated(p%gof)) deallocate (p%gof)
        if (allocated(p%binv)) deallocate (p%binv)
        if (allocated(p%r)) deallocate (p%r, p%z, p%p, p%q)
        if (allocated(p%loc)) deallocate (p%loc)
        if (allocated(p%kd)) deallocate (p%kd)
        if (allocated(p%dg)) deallocate (p%dg, p%sd)
        p%b2 = e2
        p%b3 = e3
        p%n = 0
        p%ng = 0
        p%bs = 1
    end subroutine pcg_free
end module pcg
