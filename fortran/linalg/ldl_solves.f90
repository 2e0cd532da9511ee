!> Triangular solves with LDL^T factors copied out of CHOLMOD (cholmod_shim.c's
!> dc_cholmod_export), in the layout of 2x2 node blocks.
!>
!> When the matrix is made of the 2x2 blocks of node pairs and the ordering keeps each
!> pair together (the shim does so), L is made of 2x2 blocks too: block column J (dofs
!> 2J-1, 2J of the permuted matrix) has a unit lower diagonal block [1 0; l21 1] and
!> full 2x2 blocks below it. Stored by blocks (one row index for four entries, the
!> entries of a block adjacent), the forward and backward sweeps treat a block's two
!> rows as one 2-vector, which the compiler packs into SIMD multiplies and adds: about
!> 1.4x faster than cholmod_solve2 on the same factor (docs/performance.md, "The
!> solves"), which chases one row index per entry. The results differ from
!> cholmod_solve2's by round-off (another order of the same products).
module ldl_solves
    use kinds, only: dp
    implicit none
    private

    !> LDL^T factors by 2x2 blocks of node pairs.
    type, public :: pair_ldl_t
        integer :: n = 0                          !! matrix size (even; 0: no factors)
        integer :: nn = 0                         !! node pairs (n/2)
        integer, allocatable :: perm(:)           !! (n) row k of P A P^T is row perm(k) of A
        integer, allocatable :: bp(:)             !! (nn + 1) blocks of each block column
        integer, allocatable :: bi(:)             !! (n_blocks) first row of the block (odd)
        real(dp), allocatable :: bx(:, :)         !! (4, n_blocks) l11, l21, l12, l22
        real(dp), allocatable :: l21(:)           !! (nn) L's entry in each diagonal block
        real(dp), allocatable :: d(:)             !! (n) D
        real(dp), allocatable :: y(:)             !! (n) work vector of the solves
    end type pair_ldl_t

    public :: pair_ldl_build, pair_ldl_solve, pair_ldl_solve_many, pair_ldl_free

contains

    !> The block copy of the factor P A P^T = L D L^T given by columns (0-based perm,
    !> colptr, rowind as dc_cholmod_export gives them; each column's first entry its
    !> diagonal D, then L's entries below it, rows ascending). ok = .false. (and f
    !> empty) when L is not made of 2x2 blocks of the pairs (2J-1, 2J).
    pure subroutine pair_ldl_build(f, n, perm, colptr, rowind, val, ok)
        type(pair_ldl_t), intent(inout) :: f                !! block factors (replaced)
        integer, intent(in) :: n                            !! size
        integer, intent(in) :: perm(:)                      !! (n) 0-based permutation
        integer, intent(in) :: colptr(:)                    !! (n + 1) 0-based column starts
        integer, intent(in) :: rowind(:)                    !! 0-based rows
        real(dp), intent(in) :: val(:)                      !! D and L by columns
        logical, intent(out) :: ok                          !! L is made of 2x2 blocks
        integer :: jb, c0, c1, p0, p1, e0, e1, nb, i
        call pair_ldl_free(f)
        ok = .false.
        if (n < 2 .or. mod(n, 2) /= 0) return
        f%nn = n / 2
        allocate (f%perm(n), f%bp(f%nn + 1), f%l21(f%nn), f%d(n), f%y(n))
        ! count the blocks and check the structure
        nb = 0
        do jb = 1, f%nn
            c0 = 2 * jb - 1
            c1 = 2 * jb
            p0 = colptr(c0) + 1; e0 = colptr(c0 + 1)
            p1 = colptr(c1) + 1; e1 = colptr(c1 + 1)
            ! column c0: diagonal, then row c1, then the pairs; column c1: diagonal, pairs
            if (e0 - p0 + 1 < 2 .or. e0 - p0 /= e1 - p1 + 1) return
            if (rowind(p0) + 1 /= c0 .or. rowind(p0 + 1) + 1 /= c1 .or. rowind(p1) + 1 /= c1) return
            do i = 0, (e1 - p1) / 2 - 1
                if (mod(rowind(p0 + 2 + 2 * i), 2) /= 0) return
                if (rowind(p0 + 3 + 2 * i) /= rowind(p0 + 2 + 2 * i) + 1) return
                if (rowind(p1 + 1 + 2 * i) /= rowind(p0 + 2 + 2 * i)) return
                if (rowind(p1 + 2 + 2 * i) /= rowind(p0 + 3 + 2 * i)) return
            end do
            if (mod(e1 - p1, 2) /= 0) return
            nb = nb + (e1 - p1) / 2
        end do
        allocate (f%bi(nb), f%bx(4, nb))
        nb = 0
        do jb = 1, f%nn
            c0 = 2 * jb - 1
            c1 = 2 * jb
            p0 = colptr(c0) + 1
            p1 = colptr(c1) + 1
            f%bp(jb) = nb + 1
            f%d(c0) = val(p0)
            f%d(c1) = val(p1)
            f%l21(jb) = val(p0 + 1)
            do i = 0, (colptr(c1 + 1) - p1) / 2 - 1
                nb = nb + 1
                f%bi(nb) = rowind(p0 + 2 + 2 * i) + 1
                f%bx(:, nb) = [val(p0 + 2 + 2 * i), val(p0 + 3 + 2 * i), &
                               val(p1 + 1 + 2 * i), val(p1 + 2 + 2 * i)]
            end do
        end do
        f%bp(f%nn + 1) = nb + 1
        f%perm = perm(1:n) + 1
        f%n = n
        ok = .true.
    end subroutine pair_ldl_build

    !> x = A^{-1} b with the block factors (b and x: n entries; they may not alias).
    pure subroutine pair_ldl_solve(f, b, x)
        type(pair_ldl_t), intent(inout) :: f                !! block factors (work vector used)
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(out) :: x(:)                       !! solution (n)
        call pair_sweeps(f%n, f%nn, size(f%bi), f%perm, f%bp, f%bi, f%bx, f%l21, f%d, b, x, f%y)
    end subroutine pair_ldl_solve

    !> X = A^{-1} B for the k columns of B with one pass over the factor for all of them
    !> (the factor is read once per k columns instead of once per column: the solves of
    !> many right-hand sides are bound by reading L). Each column gets the operations of
    !> pair_ldl_solve in the same order.
    pure subroutine pair_ldl_solve_many(f, b, x)
        type(pair_ldl_t), intent(in) :: f                   !! block factors
        real(dp), intent(in) :: b(:, :)                     !! right-hand sides (n, k)
        real(dp), intent(out) :: x(:, :)                    !! solutions (n, k)
        real(dp), allocatable :: y(:, :)
        allocate (y(size(b, 2), f%n))
        call pair_sweeps_many(f%n, f%nn, size(f%bi), size(b, 2), f%perm, f%bp, f%bi, f%bx, &
                              f%l21, f%d, b, x, y)
    end subroutine pair_ldl_solve_many

    !> pair_sweeps for k right-hand sides, the work array by rows (y(:, i): row i of the
    !> k columns, adjacent).
    pure subroutine pair_sweeps_many(n, nn, nb, k, perm, bp, bi, bx, l21, d, b, x, y)
        integer, intent(in) :: n, nn, nb, k                 !! size, pairs, blocks, columns
        integer, intent(in) :: perm(n), bp(nn + 1), bi(nb)  !! permutation, block structure
        real(dp), intent(in) :: bx(4, nb), l21(nn), d(n)    !! L's blocks, diagonal blocks, D
        real(dp), intent(in) :: b(n, k)                     !! right-hand sides
        real(dp), intent(out) :: x(n, k)                    !! solutions
        real(dp), intent(out) :: y(k, n)                    !! work
        real(dp) :: y0(k), y1(k), s1(k), s2(k), s3(k), s4(k)
        integer :: jb, q, i, c
        do i = 1, n
            y(:, i) = b(perm(i), :)
        end do
        do jb = 1, nn
            y0 = y(:, 2 * jb - 1)
            y1 = y(:, 2 * jb) - l21(jb) * y0
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                y(:, i) = y(:, i) - (bx(1, q) * y0 + bx(3, q) * y1)
                y(:, i + 1) = y(:, i + 1) - (bx(2, q) * y0 + bx(4, q) * y1)
            end do
            y(:, 2 * jb - 1) = y0 / d(2 * jb - 1)
            y(:, 2 * jb) = y1 / d(2 * jb)
        end do
        do jb = nn, 1, -1
            s1 = 0.0_dp; s2 = 0.0_dp; s3 = 0.0_dp; s4 = 0.0_dp
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                s1 = s1 + bx(1, q) * y(:, i)
                s2 = s2 + bx(2, q) * y(:, i + 1)
                s3 = s3 + bx(3, q) * y(:, i)
                s4 = s4 + bx(4, q) * y(:, i + 1)
            end do
            y1 = y(:, 2 * jb) - (s3 + s4)
            y0 = y(:, 2 * jb - 1) - (s1 + s2) - l21(jb) * y1
            y(:, 2 * jb) = y1
            y(:, 2 * jb - 1) = y0
            do c = 1, k
                x(perm(2 * jb), c) = y1(c)
                x(perm(2 * jb - 1), c) = y0(c)
            end do
        end do
    end subroutine pair_sweeps_many

    !> The two sweeps: y = P b; L y' = y by block columns (each block's two rows updated
    !> as one 2-vector), each pair scaled by D^{-1} once final; L^T z = y' by block
    !> columns (the four products of each block summed in four partial sums), each pair
    !> stored into x = P^T z once final. Explicit-shape dummies: gfortran vectorizes the
    !> block operations only on arrays of unit stride.
    pure subroutine pair_sweeps(n, nn, nb, perm, bp, bi, bx, l21, d, b, x, y)
        integer, intent(in) :: n, nn, nb                    !! size, pairs, blocks
        integer, intent(in) :: perm(n), bp(nn + 1), bi(nb)  !! permutation, block structure
        real(dp), intent(in) :: bx(4, nb), l21(nn), d(n)    !! L's blocks, diagonal blocks, D
        real(dp), intent(in) :: b(n)                        !! right-hand side
        real(dp), intent(out) :: x(n)                       !! solution
        real(dp), intent(out) :: y(n)                       !! work
        real(dp) :: y0, y1, s(4)
        integer :: jb, q, i
        do i = 1, n
            y(i) = b(perm(i))
        end do
        do jb = 1, nn
            y0 = y(2 * jb - 1)
            y1 = y(2 * jb) - l21(jb) * y0
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                y(i:i + 1) = y(i:i + 1) - (bx(1:2, q) * y0 + bx(3:4, q) * y1)
            end do
            ! the pair is final: D^{-1} now (no pass of its own)
            y(2 * jb - 1) = y0 / d(2 * jb - 1)
            y(2 * jb) = y1 / d(2 * jb)
        end do
        do jb = nn, 1, -1
            s = 0.0_dp
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                s(1:2) = s(1:2) + bx(1:2, q) * y(i:i + 1)
                s(3:4) = s(3:4) + bx(3:4, q) * y(i:i + 1)
            end do
            y1 = y(2 * jb) - (s(3) + s(4))
            y0 = y(2 * jb - 1) - (s(1) + s(2)) - l21(jb) * y1
            y(2 * jb) = y1
            y(2 * jb - 1) = y0
            ! the pair is final: P^T now (no pass of its own)
            x(perm(2 * jb)) = y1
            x(perm(2 * jb - 1)) = y0
        end do
    end subroutine pair_sweeps

    !> Release the block factors.
    pure subroutine pair_ldl_free(f)
        type(pair_ldl_t), intent(inout) :: f                !! block factors
        if (allocated(f%perm)) deallocate (f%perm)
        if (allocated(f%bp)) deallocate (f%bp)
        if (allocated(f%bi)) deallocate (f%bi)
        if (allocated(f%bx)) deallocate (f%bx)
        if (allocated(f%l21)) deallocate (f%l21)
        if (allocated(f%d)) deallocate (f%d)
        if (allocated(f%y)) deallocate (f%y)
        f%n = 0
        f%nn = 0
    end subroutine pair_ldl_free
end module ldl_solves
