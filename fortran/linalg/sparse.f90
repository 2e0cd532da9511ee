!> Compressed sparse column matrices (the layout UMFPACK reads).
!>
!> Patterns are fixed once (csc_from_coo keeps explicit zeros), so matrices assembled
!> from the same triplet positions share one pattern: their values can be combined
!> entry by entry (csc_axpby_values) and refilled without sorting (csc_coo_map +
!> csc_accumulate). Matrix-vector kernels do not allocate and do not check sizes.
module sparse
    use iso_c_binding, only: c_int
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_INTERNAL, raise
    implicit none
    private

    !> Square CSC matrix with 0-based colptr/rowind (UMFPACK's Ap, Ai); row indices
    !> sorted and unique within each column.
    type, public :: csc_t
        integer :: n = 0                              !! number of rows = columns
        integer :: nnz = 0                            !! stored entries
        integer(c_int), allocatable :: colptr(:)      !! (n+1) 0-based column starts
        integer(c_int), allocatable :: rowind(:)      !! (nnz) 0-based row indices
        real(dp), allocatable :: val(:)               !! (nnz) values
    end type csc_t

    public :: csc_from_coo, csc_find, csc_matvec, csc_matvec_t, csc_drop_zeros
    public :: csc_matvec_t_values, csc_swap_values, block2_csc_values, block3_csc_values
    public :: block2_from_csc, block2_matvec, block2_matvec_km, block2_scalar_blocks, &
              block2_matvec_ks2, block2_matvec_ks3
    public :: block3_from_csc, block3_matvec, block3_matvec_km, block3_scalar_blocks, &
              block3_matvec_ks2, block3_matvec_ks3

    !> A symmetric matrix stored by rows of 2x2 blocks: dofs grouped in runs of one or
    !> two consecutive dofs (the free dofs of a node). Each block holds the rows of a
    !> row group and the columns of a column group, padded with zeros to 2x2; a group
    !> of one dof reads its single x entry twice (col2 = col1) against a zero column.
    !> Four products per pair of index loads: about twice as fast as csc_matvec_t
    !> on 2D elasticity matrices. The products sum the two rows of a block as one
    !> 2-vector, [y1, y2] = [y1, y2] + [a11, a21] x1 + [a12, a22] x2: gfortran packs
    !> each step into one SSE2 multiply and add (x86-64 baseline, no -march), and each
    !> row keeps its summation order (bitwise equal to the scalar loop). This needs
    !> vector dummies of unit stride: gfortran 12 vectorizes the loop only from the
    !> store of a group's two results to adjacent addresses. They are explicit-shape
    !> (a contiguous actual is passed as is after a runtime stride check, where a
    !> `contiguous` assumed-shape dummy would have gfortran 12 copy every actual in and
    !> out). When every group is a pair, the kernels read x, v, d as pairs x(c:c+1)
    !> and skip col2.
    type, public :: block2_t
        integer :: n = 0                          !! matrix size
        integer :: n_groups = 0                   !! row/column groups
        integer, allocatable :: first(:)          !! (n_groups + 1) first dof of each group
        integer, allocatable :: row_ptr(:)        !! (n_groups + 1) block range of each row group
        integer, allocatable :: col1(:)           !! (n_blocks) first dof of the column group
        integer, allocatable :: col2(:)           !! (n_blocks) second dof (= col1 for a single); empty when pairs
        logical :: pairs = .false.                !! every group a pair (the second dof is col1 + 1: col2 not stored)
        real(dp), allocatable :: val(:, :)        !! (4, n_blocks) a11, a21, a12, a22
    end type block2_t

    !> block2_t for node triples (3D elasticity): a symmetric matrix by rows of 3x3 blocks,
    !> dofs grouped in runs of one to three consecutive dofs (the free dofs of a node).
    !> A block holds the rows of a row group and the columns of a column group, padded
    !> with zeros to 3x3; a group of fewer than three dofs repeats its first column index
    !> (col2, col3) against zero columns. The products sum a block's rows in the order of
    !> csc_matvec_t within each row (bitwise equal to it, as block2_t's). When every group
    !> is a triple the kernels read x as x(c:c+2) and a block's column as four adjacent
    !> entries (its three and the next one; val has a last zero block for the last read),
    !> so that a block's rows are summed as one 4-vector: one 256-bit multiply and add a
    !> column with AVX, where a 3-vector was compiled to scalar and 2-lane operations. The
    !> fourth lane is thrown away and never meets the other three (lanes are independent).
    !> Columns padded to four in memory were as fast and a third larger.
    type, public :: block3_t
        integer :: n = 0                          !! matrix size
        integer :: n_groups = 0                   !! row/column groups
        integer, allocatable :: first(:)          !! (n_groups + 1) first dof of each group
        integer, allocatable :: row_ptr(:)        !! (n_groups + 1) block range of each row group
        integer, allocatable :: col1(:)           !! (n_blocks) first dof of the column group
        integer, allocatable :: col2(:)           !! (n_blocks) second dof (= col1 if none); empty when triples
        integer, allocatable :: col3(:)           !! (n_blocks) third dof (= col1 if none); empty when triples
        logical :: triples = .false.              !! every group a triple (col_k = col1 + k - 1: col2, col3 not stored)
        real(dp), allocatable :: val(:, :)        !! (9, n_blocks + 1) by columns: a11, a21, a31, a12, ..., a33; a last zero block
    end type block3_t

contains

    !> Build an n x n CSC matrix from 1-based COO triplets (rows(k), cols(k), vals(k)),
    !> k = 1..size(rows); duplicates are summed, explicit zeros kept (they fix a pattern).
    !> Row indices come out sorted within each column. O(nnz + n) (two counting sorts).
    pure subroutine csc_from_coo(n, rows, cols, vals, a, stat, errmsg)
        integer, intent(in) :: n                            !! matrix size (>= 0)
        integer, intent(in) :: rows(:)                      !! 1-based row indices
        integer, intent(in) :: cols(:)                      !! 1-based column indices
        real(dp), intent(in) :: vals(:)                     !! values
        type(csc_t), intent(out) :: a                       !! result
        integer, intent(out) :: stat                        !! STAT_OK, STAT_BAD_INPUT (bad index)
        character(len=*), intent(inout), optional :: errmsg !! message
        integer, allocatable :: rowstart(:), byrow(:), colnext(:), trow(:)
        real(dp), allocatable :: tval(:)
        integer :: ntrip, k, kk, i, j, p, q, last, nout, ierr
        character(len=160) :: buf

        ntrip = size(rows)
        if (n < 0) then
            write (buf, '(a,i0)') 'csc_from_coo: negative matrix size ', n
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
            return
        end if
        if (size(cols) /= ntrip .or. size(vals) /= ntrip) then
            write (buf, '(a,3(1x,i0))') 'csc_from_coo: rows, cols, vals differ in length:', &
                ntrip, size(cols), size(vals)
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
            return
        end if
        do k = 1, ntrip
            if (rows(k) < 1 .or. rows(k) > n .or. cols(k) < 1 .or. cols(k) > n) then
                write (buf, '(a,i0,a,i0,a,i0,a,i0)') 'csc_from_coo: index out of range in entry ', &
                    k, ': (', rows(k), ', ', cols(k), '), n = ', n
                call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
                return
            end if
        end do

        allocate (rowstart(n + 1), byrow(ntrip), colnext(n + 1), trow(ntrip), tval(ntrip), &
                  stat=ierr)
        if (ierr /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, 'csc_from_coo: out of memory')
            return
        end if

        ! Counting sort of the triplets by row (stable): byrow lists k by increasing row.
        rowstart = 0
        do k = 1, ntrip
            rowstart(rows(k) + 1) = rowstart(rows(k) + 1) + 1
        end do
        rowstart(1) = 1
        do i = 1, n
            rowstart(i + 1) = rowstart(i + 1) + rowstart(i)
        end do
        do k = 1, ntrip                    ! rowstart(i) = next free slot of row i
            i = rows(k)
            byrow(rowstart(i)) = k
            rowstart(i) = rowstart(i) + 1
        end do

        ! Column counts, then distribute in row order: rows ascend within each column.
        colnext = 0
        do k = 1, ntrip
            colnext(cols(k) + 1) = colnext(cols(k) + 1) + 1
        end do
        colnext(1) = 1
        do j = 1, n
            colnext(j + 1) = colnext(j + 1) + colnext(j)
        end do
        ! colnext(j) = first slot of column j (1-based); keep the starts in rowstart
        rowstart = colnext
        do kk = 1, ntrip
            k = byrow(kk)
            j = cols(k)
            trow(colnext(j)) = rows(k)
            tval(colnext(j)) = vals(k)
            colnext(j) = colnext(j) + 1
        end do

        ! Sum adjacent duplicates in place; colnext(j) becomes the compacted start.
        nout = 0
        do j = 1, n
            p = rowstart(j)
            q = rowstart(j + 1) - 1
            colnext(j) = nout
            last = 0
            do k = p, q
                if (trow(k) == last) then
                    tval(nout) = tval(nout) + tval(k)
                else
                    nout = nout + 1
                    trow(nout) = trow(k)
                    tval(nout) = tval(k)
                    last = trow(k)
                end if
            end do
        end do
        colnext(n + 1) = nout

        a%n = n
        a%nnz = nout
        allocate (a%colptr(n + 1), a%rowind(nout), a%val(nout), stat=ierr)
        if (ierr /= 0) then
            a%n = 0
            a%nnz = 0
            call raise(stat, errmsg, STAT_INTERNAL, 'csc_from_coo: out of memory')
            return
        end if
        a%colptr = int(colnext, c_int)
        a%rowind = int(trow(1:nout) - 1, c_int)
        a%val = tval(1:nout)
        stat = STAT_OK
    end subroutine csc_from_coo

    !> 1-based position in a%val of entry (i, j) (1-based), 0 if not stored or out of
    !> range. Binary search in column j: O(log(entries of column j)).
    pure function csc_find(a, i, j) result(pos)
        type(csc_t), intent(in) :: a   !! matrix
        integer, intent(in) :: i       !! row (1-based)
        integer, intent(in) :: j       !! column (1-based)
        integer :: pos
        integer :: lo, hi, mid, r
        pos = 0
        if (i < 1 .or. i > a%n .or. j < 1 .or. j > a%n) return
        r = i - 1
        lo = a%colptr(j) + 1          ! 1-based positions of column j: lo..hi
        hi = a%colptr(j + 1)
        do while (lo <= hi)
            mid = lo + (hi - lo) / 2
            if (a%rowind(mid) < r) then
                lo = mid + 1
            else if (a%rowind(mid) > r) then
                hi = mid - 1
            else
                pos = mid
                return
            end if
        end do
    end function csc_find

    !> y = A x. x and y must have (at least) n entries and must not alias.
    pure subroutine csc_matvec(a, x, y)
        type(csc_t), intent(in) :: a   !! matrix
        real(dp), intent(in) :: x(:)   !! (n)
        real(dp), intent(out) :: y(:)  !! (n)
        integer :: j, k
        real(dp) :: xj
        y(1:a%n) = 0.0_dp
        do j = 1, a%n
            xj = x(j)
            do k = a%colptr(j) + 1, a%colptr(j + 1)
                y(a%rowind(k) + 1) = y(a%rowind(k) + 1) + a%val(k) * xj
            end do
        end do
    end subroutine csc_matvec

    !> y = A^T x (gathers, no scattered writes: the fast product for a symmetric A,
    !> where it equals A x). x and y must have (at least) n entries and must not alias.
    pure subroutine csc_matvec_t(a, x, y)
        type(csc_t), intent(in) :: a   !! matrix
        real(dp), intent(in) :: x(:)   !! (n)
        real(dp), intent(out) :: y(:)  !! (n)
        call csc_matvec_t_values(a, a%val, x, y)
    end subroutine csc_matvec_t

    !> y = B^T x for the matrix B with a's pattern and the values val (a%val is not
    !> read): matrices that share one pattern keep their values only. csc_matvec_t is
    !> this with a's own values.
    pure subroutine csc_matvec_t_values(a, val, x, y)
        type(csc_t), intent(in) :: a   !! the pattern
        real(dp), intent(in) :: val(:) !! (a%nnz) values on it
        real(dp), intent(in) :: x(:)   !! (n)
        real(dp), intent(out) :: y(:)  !! (n)
        integer :: j, k
        real(dp) :: acc
        do j = 1, a%n
            acc = 0.0_dp
            do k = a%colptr(j) + 1, a%colptr(j + 1)
                acc = acc + val(k) * x(a%rowind(k) + 1)
            end do
            y(j) = acc
        end do
    end subroutine csc_matvec_t_values

    !> Exchange a%val with val (same size, values on a's pattern), without a copy: a
    !> routine that takes a csc_t then reads the other matrix; a second call restores.
    pure subroutine csc_swap_values(a, val)
        type(csc_t), intent(inout) :: a               !! the pattern and its values
        real(dp), allocatable, intent(inout) :: val(:) !! (a%nnz) the other values
        real(dp), allocatable :: keep(:)
        call move_alloc(a%val, keep)
        call move_alloc(val, a%val)
        call move_alloc(keep, val)
    end subroutine csc_swap_values

    !> Block copy of a symmetric CSC matrix; `first` (n_groups + 1) gives the first dof
    !> of each group of 1 or 2 consecutive dofs (first(n_groups + 1) = n + 1). With
    !> `val`, the copy is of the matrix with a's pattern and those values.
    pure subroutine block2_from_csc(a, first, b, stat, errmsg, val)
        type(csc_t), intent(in) :: a                        !! symmetric matrix
        integer, intent(in) :: first(:)                     !! group starts
        type(block2_t), intent(out) :: b                    !! block copy
        integer, intent(out) :: stat                        !! STAT_OK, STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern, read
                                                            !! in place of a%val
        integer, allocatable :: unused_col3(:)
        call blocks_from_csc(a, first, 2, 'block2_from_csc', b%n, b%n_groups, b%first, b%row_ptr, &
                             b%col1, b%col2, unused_col3, b%pairs, b%val, stat, errmsg, val)
    end subroutine block2_from_csc

    !> y = B x for a block2_t matrix (rows of a block summed as a 2-vector, see block2_t).
    pure subroutine block2_matvec(b, x, y)
        type(block2_t), intent(in) :: b                    !! matrix
        real(dp), intent(in) :: x(b%n)                     !! (n)
        real(dp), intent(out) :: y(b%n)                    !! (n)
        integer :: g, k, i
        real(dp) :: s(2)
        if (b%pairs) then   ! x read as pairs, no col2 load (~10 % faster)
            call pairs_rows(b%n, b%n_groups, size(b%col1), b%row_ptr, b%col1, b%first, b%val, x, y)
            return
        end if
        do g = 1, b%n_groups
            s = 0.0_dp
            do k = b%row_ptr(g), b%row_ptr(g + 1) - 1
                s = s + b%val(1:2, k) * x(b%col1(k)) + b%val(3:4, k) * x(b%col2(k))
            end do
            i = b%first(g)
            if (b%first(g + 1) - i == 2) then
                y(i:i + 1) = s
            else
                y(i) = s(1)
            end if
        end do
    end subroutine block2_matvec

    !> block2_matvec when every group is a pair, on the arrays of b. The pair kernels take
    !> the matrix's arrays as explicit-shape dummies: gfortran then keeps their addresses
    !> in registers across rows; through the derived type it reloaded them from the
    !> descriptors at every row (~20 instructions a row instead of ~9; a block is ~17).
    pure subroutine pairs_rows(n, ng, nb, row_ptr, col1, first, val, x, y)
        integer, intent(in) :: n, ng, nb                   !! size, groups, blocks
        integer, intent(in) :: row_ptr(ng + 1)             !! block range of each row group
        integer, intent(in) :: col1(nb)                    !! first dof of each block's column group
        integer, intent(in) :: first(ng + 1)               !! first dof of each group
        real(dp), intent(in) :: val(4, nb)                 !! blocks
        real(dp), intent(in) :: x(n)                       !! vector
        real(dp), intent(out) :: y(n)                      !! product
        integer :: g, k, c, i
        real(dp) :: s(2)
        do g = 1, ng
            s = 0.0_dp
            do k = row_ptr(g), row_ptr(g + 1) - 1
                c = col1(k)
                s = s + val(1:2, k) * x(c) + val(3:4, k) * x(c + 1)
            end do
            i = first(g)
            y(i:i + 1) = s
        end do
    end subroutine pairs_rows

    !> kx = K x, mv = M v and md = M d in one pass over the blocks, for two block2_t
    !> matrices built from one CSC pattern (same groups and blocks, as block2_from_csc
    !> gives for K_theta and M): the index loads are shared by the three products.
    !> Each row sum is accumulated in the order of block2_matvec (kx is bitwise equal).
    pure subroutine block2_matvec_km(kb, mb, x, v, d, kx, mv, md)
        type(block2_t), intent(in) :: kb                   !! K
        type(block2_t), intent(in) :: mb                   !! M, same block pattern as kb
        real(dp), intent(in) :: x(kb%n)                    !! (n) vector multiplied by K
        real(dp), intent(in) :: v(kb%n)                    !! (n) first vector multiplied by M
        real(dp), intent(in) :: d(kb%n)                    !! (n) second vector multiplied by M
        real(dp), intent(out) :: kx(kb%n)                  !! (n) K x
        real(dp), intent(out) :: mv(kb%n)                  !! (n) M v
        real(dp), intent(out) :: md(kb%n)                  !! (n) M d
        integer :: g, k, c1, c2, i
        real(dp) :: y(2), p(2), q(2)
        do g = 1, kb%n_groups
            y = 0.0_dp
            p = 0.0_dp
            q = 0.0_dp
            do k = kb%row_ptr(g), kb%row_ptr(g + 1) - 1
                c1 = kb%col1(k)
                if (kb%pairs) then
                    c2 = c1 + 1
                else
                    c2 = kb%col2(k)
                end if
                y = y + kb%val(1:2, k) * x(c1) + kb%val(3:4, k) * x(c2)
                p = p + mb%val(1:2, k) * v(c1) + mb%val(3:4, k) * v(c2)
                q = q + mb%val(1:2, k) * d(c1) + mb%val(3:4, k) * d(c2)
            end do
            i = kb%first(g)
            if (kb%first(g + 1) - i == 2) then
                kx(i:i + 1) = y
                mv(i:i + 1) = p
                md(i:i + 1) = q
            else
                kx(i) = y(1)
                mv(i) = p(1)
                md(i) = q(1)
            end if
        end do
    end subroutine block2_matvec_km

    !> When every block of b is s I (a21 = a12 = 0, a11 = a22, every group a pair of
    !> dofs), as the P1 mass of 2D elasticity is, the scalars s of its blocks.
    pure subroutine block2_scalar_blocks(b, s, ok)
        type(block2_t), intent(in) :: b                  !! matrix
        real(dp), allocatable, intent(out) :: s(:)       !! (n_blocks) the scalars
        logical, intent(out) :: ok                       !! b has that form
        ok = b%n_groups > 0 .and. b%pairs
        call scalar_blocks(2, size(b%col1), b%val, s, ok)
    end subroutine block2_scalar_blocks

    !> kx = K x and mv = M v in one pass, M = blocks ms(k) I on the block pattern of kb
    !> (see block2_scalar_blocks). kx is bitwise equal to block2_matvec's.
    pure subroutine block2_matvec_ks2(kb, ms, x, v, kx, mv)
        type(block2_t), intent(in) :: kb                   !! K (every group a pair)
        real(dp), intent(in) :: ms(size(kb%col1))          !! (n_blocks) scalar blocks of M
        real(dp), intent(in) :: x(kb%n)                    !! (n) vector multiplied by K
        real(dp), intent(in) :: v(kb%n)                    !! (n) vector multiplied by M
        real(dp), intent(out) :: kx(kb%n)                  !! (n) K x
        real(dp), intent(out) :: mv(kb%n)                  !! (n) M v
        call ks2_rows(kb%n, kb%n_groups, size(kb%col1), kb%row_ptr, kb%col1, kb%first, kb%val, &
                      ms, x, v, kx, mv)
    end subroutine block2_matvec_ks2

    !> block2_matvec_ks2 on the arrays of K (explicit shapes, see pairs_rows).
    pure subroutine ks2_rows(n, ng, nb, row_ptr, col1, first, val, ms, x, v, kx, mv)
        integer, intent(in) :: n, ng, nb                   !! size, groups, blocks
        integer, intent(in) :: row_ptr(ng + 1)             !! block range of each row group
        integer, intent(in) :: col1(nb)                    !! first dof of each block's column group
        integer, intent(in) :: first(ng + 1)               !! first dof of each group
        real(dp), intent(in) :: val(4, nb)                 !! blocks of K
        real(dp), intent(in) :: ms(nb)                     !! scalar blocks of M
        real(dp), intent(in) :: x(n), v(n)                 !! vectors
        real(dp), intent(out) :: kx(n), mv(n)              !! K x, M v
        integer :: g, k, c, i
        real(dp) :: y(2), p(2)
        do g = 1, ng
            y = 0.0_dp
            p = 0.0_dp
            do k = row_ptr(g), row_ptr(g + 1) - 1
                c = col1(k)
                y = y + val(1:2, k) * x(c) + val(3:4, k) * x(c + 1)
                p = p + ms(k) * v(c:c + 1)
            end do
            i = first(g)
            kx(i:i + 1) = y
            mv(i:i + 1) = p
        end do
    end subroutine ks2_rows

    !> kx = K x, mv = M v and md = M d in one pass, M = blocks ms(k) I on the block
    !> pattern of kb (see block2_scalar_blocks). kx is bitwise equal to block2_matvec's.
    pure subroutine block2_matvec_ks3(kb, ms, x, v, d, kx, mv, md, bx)
        type(block2_t), intent(in) :: kb                   !! K (every group a pair)
        real(dp), intent(in) :: ms(size(kb%col1))          !! (n_blocks) scalar blocks of M
        real(dp), intent(in) :: x(kb%n)                    !! (n) vector multiplied by K
        real(dp), intent(in) :: v(kb%n)                    !! (n) first vector multiplied by M
        real(dp), intent(in) :: d(kb%n)                    !! (n) second vector multiplied by M
        real(dp), intent(out) :: kx(kb%n)                  !! (n) K x
        real(dp), intent(out) :: mv(kb%n)                  !! (n) M v
        real(dp), intent(out) :: md(kb%n)                  !! (n) M d
        real(dp), intent(out) :: bx(kb%n)                  !! (n) K x again
        call ks3_rows(kb%n, kb%n_groups, size(kb%col1), kb%row_ptr, kb%col1, kb%first, kb%val, &
                      ms, x, v, d, kx, mv, md, bx)
    end subroutine block2_matvec_ks3

    !> block2_matvec_ks3 on the arrays of K (explicit shapes, see pairs_rows).
    pure subroutine ks3_rows(n, ng, nb, row_ptr, col1, first, val, ms, x, v, d, kx, mv, md, bx)
        integer, intent(in) :: n, ng, nb                   !! size, groups, blocks
        integer, intent(in) :: row_ptr(ng + 1)             !! block range of each row group
        integer, intent(in) :: col1(nb)                    !! first dof of each block's column group
        integer, intent(in) :: first(ng + 1)               !! first dof of each group
        real(dp), intent(in) :: val(4, nb)                 !! blocks of K
        real(dp), intent(in) :: ms(nb)                     !! scalar blocks of M
        real(dp), intent(in) :: x(n), v(n), d(n)           !! vectors
        real(dp), intent(out) :: kx(n), mv(n), md(n)       !! K x, M v, M d
        real(dp), intent(out) :: bx(n)                     !! K x again
        integer :: g, k, c, i
        real(dp) :: y(2), p(2), q(2)
        do g = 1, ng
            y = 0.0_dp
            p = 0.0_dp
            q = 0.0_dp
            do k = row_ptr(g), row_ptr(g + 1) - 1
                c = col1(k)
                y = y + val(1:2, k) * x(c) + val(3:4, k) * x(c + 1)
                p = p + ms(k) * v(c:c + 1)
                q = q + ms(k) * d(c:c + 1)
            end do
            i = first(g)
            kx(i:i + 1) = y
            bx(i:i + 1) = y
            mv(i:i + 1) = p
            md(i:i + 1) = q
        end do
    end subroutine ks3_rows

    !> Block copy of a symmetric CSC matrix by node triples; `first` (n_groups + 1) gives
    !> the first dof of each group of 1 to 3 consecutive dofs (first(n_groups + 1) = n + 1),
    !> of the matrix with a's pattern and the values `val` when given.
    pure subroutine block3_from_csc(a, first, b, stat, errmsg, val)
        type(csc_t), intent(in) :: a                        !! symmetric matrix
        integer, intent(in) :: first(:)                     !! group starts
        type(block3_t), intent(out) :: b                    !! block copy
        integer, intent(out) :: stat                        !! STAT_OK, STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern, read
                                                            !! in place of a%val
        call blocks_from_csc(a, first, 3, 'block3_from_csc', b%n, b%n_groups, b%first, b%row_ptr, &
                             b%col1, b%col2, b%col3, b%triples, b%val, stat, errmsg, val)
    end subroutine block3_from_csc

    !> block2_from_csc (w = 2) and block3_from_csc (w = 3) on the components of the copy:
    !> check that `first` splits a's n dofs into groups of 1 to w consecutive dofs
    !> (first(1) = 1, first(n_groups + 1) = n + 1; else STAT_BAD_INPUT, message `who`: bad
    !> groups), lay out the blocks (block_layout) and scatter the values into them. A
    !> group of fewer than w dofs repeats its first column index (col2, col3; col3 = col1
    !> when w = 2); both are empty when every group has w dofs. For w = 3 the values end
    !> with a zero block (block3_t).
    pure subroutine blocks_from_csc(a, first, w, who, n, n_groups, bfirst, row_ptr, col1, col2, col3, &
                               full, bval, stat, errmsg, val)
        type(csc_t), intent(in) :: a                        !! symmetric matrix
        integer, intent(in) :: first(:)                     !! group starts
        integer, intent(in) :: w                            !! most dofs of a group (block width)
        character(len=*), intent(in) :: who                 !! caller, for the message
        integer, intent(out) :: n                           !! the copy's size
        integer, intent(out) :: n_groups                    !! its groups
        integer, allocatable, intent(out) :: bfirst(:)      !! its group starts (= first)
        integer, allocatable, intent(out) :: row_ptr(:)     !! block range of each row group
        integer, allocatable, intent(out) :: col1(:)        !! first dof of the column group
        integer, allocatable, intent(out) :: col2(:)        !! second dof (= col1 if none)
        integer, allocatable, intent(out) :: col3(:)        !! third dof (= col1 if none)
        logical, intent(out) :: full                        !! every group has w dofs
        real(dp), allocatable, intent(out) :: bval(:, :)    !! (w * w, n_blocks [+ 1]) block values
        integer, intent(out) :: stat                        !! STAT_OK, STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values read in place of a%val
        integer, allocatable :: width(:), group(:), mark(:), place(:)
        integer :: ng, g, k0, m
        stat = STAT_OK
        n = 0
        n_groups = 0
        full = .false.
        ng = size(first) - 1
        if (ng < 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, who//': bad groups')
            return
        end if
        if (first(1) /= 1 .or. first(ng + 1) /= a%n + 1 .or. any(first(2:) - first(:ng) < 1) &
            .or. any(first(2:) - first(:ng) > w)) then
            call raise(stat, errmsg, STAT_BAD_INPUT, who//': bad groups')
            return
        end if
        n = a%n
        n_groups = ng
        bfirst = first
        full = all(first(2:) - first(:ng) == w)
        call block_layout(a, first, row_ptr, col1, width)
        if (full) then
            allocate (col2(0), col3(0))
        else
            col2 = col1 + merge(1, 0, width >= 2)
            col3 = col1 + merge(2, 0, width >= 3)
        end if
        allocate (bval(w * w, size(col1) + merge(1, 0, w == 3)), stat=m)
        if (m /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, who//': out of memory (the block values)')
            return
        end if
        bval = 0.0_dp
        ! the values row group by row group: a group's columns are consecutive entries of a
        call group_work(a, first, group, mark, place)
        do g = 1, ng
            call group_places(a, first, w, group, row_ptr, col1, g, mark, place, m)
            k0 = a%colptr(first(g))
            if (present(val)) then
                call put_places(size(bval), bval, place(1:m), val(k0 + 1:k0 + m))
            else
                call put_places(size(bval), bval, place(1:m), a%val(k0 + 1:k0 + m))
            end if
        end do
    end subroutine blocks_from_csc

    !> bv(pl(e)) = v(e): values put at their places in the blocks' values.
    pure subroutine put_places(nv, bv, pl, v)
        integer, intent(in) :: nv                           !! size of bv
        real(dp), intent(inout) :: bv(nv)                   !! blocks' values, block after block
        integer, intent(in) :: pl(:)                        !! places
        real(dp), intent(in) :: v(size(pl))                 !! values
        bv(pl) = v
    end subroutine put_places

    !> The node-block layout of the symmetric pattern of a for the groups `first`
    !> (checked): a's columns by row groups, a row group's blocks numbered as their column
    !> groups are met. Block k holds rows of its row group and columns col1(k) ..
    !> col1(k) + width(k) - 1.
    pure subroutine block_layout(a, first, row_ptr, col1, width)
        type(csc_t), intent(in) :: a                        !! symmetric pattern
        integer, intent(in) :: first(:)                     !! (n_groups + 1) group starts
        integer, allocatable, intent(out) :: row_ptr(:)     !! (n_groups + 1) row groups' blocks
        integer, allocatable, intent(out) :: col1(:)        !! (n_blocks) column group's first dof
        integer, allocatable, intent(out) :: width(:)       !! (n_blocks) dofs of the column group
        integer, allocatable :: group(:), mark(:), place(:)
        integer :: ng, g, j, k, h, nb
        ng = size(first) - 1
        call group_work(a, first, group, mark, place)
        allocate (row_ptr(ng + 1))
        ! count blocks per row group (A symmetric: column j of A is row j)
        mark = 0
        nb = 0
        row_ptr(1) = 1
        do g = 1, ng
            do j = first(g), first(g + 1) - 1
                do k = a%colptr(j) + 1, a%colptr(j + 1)
                    h = group(a%rowind(k) + 1)
                    if (mark(h) /= g) then
                        mark(h) = g
                        nb = nb + 1
                    end if
                end do
            end do
            row_ptr(g + 1) = nb + 1
        end do
        allocate (col1(nb), width(nb))
        mark = 0
        nb = 0
        do g = 1, ng
            do j = first(g), first(g + 1) - 1
                do k = a%colptr(j) + 1, a%colptr(j + 1)
                    h = group(a%rowind(k) + 1)
                    if (mark(h) < row_ptr(g)) then
                        nb = nb + 1
                        mark(h) = nb
                        col1(nb) = first(h)
                        width(nb) = first(h + 1) - first(h)
                    end if
                end do
            end do
        end do
    end subroutine block_layout

    !> Work arrays of the walks by row groups: each dof's group, a mark a group, and room
    !> for the places of one row group's entries (the most entries of a row group).
    pure subroutine group_work(a, first, group, mark, place)
        type(csc_t), intent(in) :: a                        !! pattern
        integer, intent(in) :: first(:)                     !! (n_groups + 1) group starts
        integer, allocatable, intent(out) :: group(:)       !! (n) each dof's group
        integer, allocatable, intent(out) :: mark(:)        !! (n_groups) work
        integer, allocatable, intent(out) :: place(:)       !! room for one row group's places
        integer :: ng, g, most
        ng = size(first) - 1
        allocate (group(a%n), mark(ng))
        most = 0
        do g = 1, ng
            group(first(g):first(g + 1) - 1) = g
            most = max(most, a%colptr(first(g + 1)) - a%colptr(first(g)))
        end do
        allocate (place(most))
    end subroutine group_work

    !> The places, in the blocks' values stored block after block (each w x w by columns),
    !> of the m entries of row group g's columns of a (entries colptr(first(g)) + 1 ..
    !> colptr(first(g + 1)), in order): entry (row i, column j) is row j - first(g), column
    !> i - first(h) of the block of row group g whose column group h holds i (A(j, i) =
    !> A(i, j)).
    pure subroutine group_places(a, first, w, group, row_ptr, col1, g, mark, place, m)
        type(csc_t), intent(in) :: a                        !! pattern
        integer, intent(in) :: first(:)                     !! (n_groups + 1) group starts
        integer, intent(in) :: w                            !! block width (2 or 3)
        integer, intent(in) :: group(:)                     !! (n) each dof's group
        integer, intent(in) :: row_ptr(:)                   !! (n_groups + 1) row groups' blocks
        integer, intent(in) :: col1(:)                      !! (n_blocks) column group's first dof
        integer, intent(in) :: g                            !! row group
        integer, intent(inout) :: mark(:)                   !! (n_groups) work
        integer, intent(inout) :: place(:)                  !! (>= m) the places
        integer, intent(out) :: m                           !! entries of the row group
        integer :: b, j, k, i, h
        do b = row_ptr(g), row_ptr(g + 1) - 1
            mark(group(col1(b))) = b
        end do
        m = 0
        do j = first(g), first(g + 1) - 1
            do k = a%colptr(j) + 1, a%colptr(j + 1)
                i = a%rowind(k) + 1
                h = group(i)
                m = m + 1
                place(m) = w * w * (mark(h) - 1) + 1 + (j - first(g)) + w * (i - first(h))
            end do
        end do
    end subroutine group_places

    !> The values on a's pattern of the matrix whose node-block copy is b (block2_from_csc
    !> of a matrix with a's pattern): the copy read back entry by entry, the same numbers.
    !> A matrix kept in blocks needs no CSC values of its own. O(nnz).
    pure subroutine block2_csc_values(a, b, val)
        type(csc_t), intent(in) :: a        !! the pattern b was copied from
        type(block2_t), intent(in) :: b     !! the block copy
        real(dp), intent(out) :: val(:)     !! (a%nnz) the values on a's pattern
        call blocks_to_csc(a, b%first, b%row_ptr, b%col1, size(b%val), b%val, 2, val)
    end subroutine block2_csc_values

    !> block2_csc_values for a 3x3 node-block copy (block3_from_csc).
    pure subroutine block3_csc_values(a, b, val)
        type(csc_t), intent(in) :: a        !! the pattern b was copied from
        type(block3_t), intent(in) :: b     !! the block copy
        real(dp), intent(out) :: val(:)     !! (a%nnz) the values on a's pattern
        call blocks_to_csc(a, b%first, b%row_ptr, b%col1, size(b%val), b%val, 3, val)
    end subroutine block3_csc_values

    !> The inverse of the copies' scatter: each entry of a read from its place in the
    !> blocks (group_places), row group by row group.
    pure subroutine blocks_to_csc(a, first, row_ptr, col1, nv, bval, w, val)
        type(csc_t), intent(in) :: a            !! pattern
        integer, intent(in) :: first(:)         !! (n_groups + 1) group starts
        integer, intent(in) :: row_ptr(:)       !! (n_groups + 1) row groups' blocks
        integer, intent(in) :: col1(:)          !! (n_blocks) column group's first dof
        integer, intent(in) :: nv               !! size of bval
        real(dp), intent(in) :: bval(nv)        !! (w * w, n_blocks) block values by columns
        integer, intent(in) :: w                !! block width (2 or 3)
        real(dp), intent(out) :: val(:)         !! (a%nnz) values
        integer, allocatable :: group(:), mark(:), place(:)
        integer :: g, k0, m
        call group_work(a, first, group, mark, place)
        do g = 1, size(first) - 1
            call group_places(a, first, w, group, row_ptr, col1, g, mark, place, m)
            k0 = a%colptr(first(g))
            val(k0 + 1:k0 + m) = bval(place(1:m))
        end do
    end subroutine blocks_to_csc

    !> y = B x for a block3_t matrix (rows of a block summed as a 3-vector, see block3_t).
    pure subroutine block3_matvec(b, x, y)
        type(block3_t), intent(in) :: b                    !! matrix
        real(dp), intent(in) :: x(b%n)                     !! (n)
        real(dp), intent(out) :: y(b%n)                    !! (n)
        integer :: g, k, i, sz
        real(dp) :: s(3)
        if (b%triples) then
            call triples_rows(b%n, b%n_groups, size(b%col1), b%row_ptr, b%col1, b%first, b%val, x, y)
            return
        end if
        do g = 1, b%n_groups
            s = 0.0_dp
            do k = b%row_ptr(g), b%row_ptr(g + 1) - 1
                s = s + b%val(1:3, k) * x(b%col1(k)) + b%val(4:6, k) * x(b%col2(k)) &
                    + b%val(7:9, k) * x(b%col3(k))
            end do
            i = b%first(g)
            sz = b%first(g + 1) - i
            y(i:i + sz - 1) = s(1:sz)
        end do
    end subroutine block3_matvec

    !> block3_matvec when every group is a triple, on the arrays of b (explicit shapes,
    !> see pairs_rows).
    pure subroutine triples_rows(n, ng, nb, row_ptr, col1, first, val, x, y)
        integer, intent(in) :: n, ng, nb                   !! size, groups, blocks
        integer, intent(in) :: row_ptr(ng + 1)             !! block range of each row group
        integer, intent(in) :: col1(nb)                    !! first dof of each block's column group
        integer, intent(in) :: first(ng + 1)               !! first dof of each group
        real(dp), intent(in) :: val(9 * nb + 9)             !! blocks (and the zero block)
        real(dp), intent(in) :: x(n)                       !! vector
        real(dp), intent(out) :: y(n)                      !! product
        integer :: g, k, c, i, o
        real(dp) :: s(4)
        do g = 1, ng
            s = 0.0_dp
            do k = row_ptr(g), row_ptr(g + 1) - 1
                c = col1(k)
                o = 9 * (k - 1)
                s = s + val(o + 1:o + 4) * x(c) + val(o + 4:o + 7) * x(c + 1) &
                    + val(o + 7:o + 10) * x(c + 2)
            end do
            i = first(g)
            y(i:i + 2) = s(1:3)
        end do
    end subroutine triples_rows

    !> kx = K x, mv = M v and md = M d in one pass over the blocks, for two block3_t
    !> matrices built from one CSC pattern (see block2_matvec_km); kx is bitwise equal
    !> to block3_matvec's.
    pure subroutine block3_matvec_km(kb, mb, x, v, d, kx, mv, md)
        type(block3_t), intent(in) :: kb                   !! K
        type(block3_t), intent(in) :: mb                   !! M, same block pattern as kb
        real(dp), intent(in) :: x(kb%n)                    !! (n) vector multiplied by K
        real(dp), intent(in) :: v(kb%n)                    !! (n) first vector multiplied by M
        real(dp), intent(in) :: d(kb%n)                    !! (n) second vector multiplied by M
        real(dp), intent(out) :: kx(kb%n)                  !! (n) K x
        real(dp), intent(out) :: mv(kb%n)                  !! (n) M v
        real(dp), intent(out) :: md(kb%n)                  !! (n) M d
        integer :: g, k, c1, c2, c3, i, sz
        real(dp) :: y(3), p(3), q(3)
        do g = 1, kb%n_groups
            y = 0.0_dp
            p = 0.0_dp
            q = 0.0_dp
            do k = kb%row_ptr(g), kb%row_ptr(g + 1) - 1
                c1 = kb%col1(k)
                if (kb%triples) then
                    c2 = c1 + 1
                    c3 = c1 + 2
                else
                    c2 = kb%col2(k)
                    c3 = kb%col3(k)
                end if
                y = y + kb%val(1:3, k) * x(c1) + kb%val(4:6, k) * x(c2) + kb%val(7:9, k) * x(c3)
                p = p + mb%val(1:3, k) * v(c1) + mb%val(4:6, k) * v(c2) + mb%val(7:9, k) * v(c3)
                q = q + mb%val(1:3, k) * d(c1) + mb%val(4:6, k) * d(c2) + mb%val(7:9, k) * d(c3)
            end do
            i = kb%first(g)
            sz = kb%first(g + 1) - i
            kx(i:i + sz - 1) = y(1:sz)
            mv(i:i + sz - 1) = p(1:sz)
            md(i:i + sz - 1) = q(1:sz)
        end do
    end subroutine block3_matvec_km

    !> When every block of b is s I (off-diagonal entries zero, equal diagonal entries,
    !> every group a triple of dofs), as the P1 mass of 3D elasticity is, the scalars s of
    !> its blocks.
    pure subroutine block3_scalar_blocks(b, s, ok)
        type(block3_t), intent(in) :: b                  !! matrix
        real(dp), allocatable, intent(out) :: s(:)       !! (n_blocks) the scalars
        logical, intent(out) :: ok                       !! b has that form
        ok = b%n_groups > 0 .and. b%triples
        call scalar_blocks(3, size(b%col1), b%val, s, ok)
    end subroutine block3_scalar_blocks

    !> The scalars s of the first nb w x w blocks of bval when `ok` on entry and every
    !> one of them is s I (entries off the diagonal zero, diagonal entries equal); else
    !> ok false and s empty. block2_scalar_blocks and block3_scalar_blocks.
    pure subroutine scalar_blocks(w, nb, bval, s, ok)
        integer, intent(in) :: w                         !! block width (2 or 3)
        integer, intent(in) :: nb                        !! blocks
        real(dp), intent(in) :: bval(:, :)               !! (w * w, >= nb) blocks by columns
        real(dp), allocatable, intent(out) :: s(:)       !! (nb) the scalars
        logical, intent(inout) :: ok                     !! in: the other conditions; out: all
        integer :: e
        do e = 2, w * w
            if (.not. ok) exit
            if (mod(e - 1, w + 1) == 0) then   ! a diagonal entry (row = column)
                ok = all(bval(e, :nb) == bval(1, :nb))
            else
                ok = all(bval(e, :nb) == 0.0_dp)
            end if
        end do
        if (ok) then
            ! out of memory: M keeps its blocks (the same products, without the shortcut)
            allocate (s(nb), stat=e)
            ok = e == 0
            if (ok) s = bval(1, :nb)
        end if
        if (.not. ok) allocate (s(0))
    end subroutine scalar_blocks

    !> kx = K x and mv = M v in one pass, M = blocks ms(k) I on the block pattern of kb
    !> (see block3_scalar_blocks). kx is bitwise equal to block3_matvec's.
    pure subroutine block3_matvec_ks2(kb, ms, x, v, kx, mv)
        type(block3_t), intent(in) :: kb                   !! K (every group a triple)
        real(dp), intent(in) :: ms(size(kb%col1))          !! (n_blocks) scalar blocks of M
        real(dp), intent(in) :: x(kb%n)                    !! (n) vector multiplied by K
        real(dp), intent(in) :: v(kb%n)                    !! (n) vector multiplied by M
        real(dp), intent(out) :: kx(kb%n)                  !! (n) K x
        real(dp), intent(out) :: mv(kb%n)                  !! (n) M v
        call ks2_rows3(kb%n, kb%n_groups, size(kb%col1), kb%row_ptr, kb%col1, kb%first, kb%val, &
                       ms, x, v, kx, mv)
    end subroutine block3_matvec_ks2

    !> block3_matvec_ks2 on the arrays of K (explicit shapes, see pairs_rows).
    pure subroutine ks2_rows3(n, ng, nb, row_ptr, col1, first, val, ms, x, v, kx, mv)
        integer, intent(in) :: n, ng, nb                   !! size, groups, blocks
        integer, intent(in) :: row_ptr(ng + 1)             !! block range of each row group
        integer, intent(in) :: col1(nb)                    !! first dof of each block's column group
        integer, intent(in) :: first(ng + 1)               !! first dof of each group
        real(dp), intent(in) :: val(9 * nb + 9)             !! blocks of K (and the zero block)
        real(dp), intent(in) :: ms(nb)                     !! scalar blocks of M
        real(dp), intent(in) :: x(n), v(n)                 !! vectors
        real(dp), intent(out) :: kx(n), mv(n)              !! K x, M v
        integer :: g, k, c, i, o
        real(dp) :: y(4), p(3)
        do g = 1, ng
            y = 0.0_dp
            p = 0.0_dp
            do k = row_ptr(g), row_ptr(g + 1) - 1
                c = col1(k)
                o = 9 * (k - 1)
                y = y + val(o + 1:o + 4) * x(c) + val(o + 4:o + 7) * x(c + 1) &
                    + val(o + 7:o + 10) * x(c + 2)
                p = p + ms(k) * v(c:c + 2)
            end do
            i = first(g)
            kx(i:i + 2) = y(1:3)
            mv(i:i + 2) = p
        end do
    end subroutine ks2_rows3

    !> kx = K x, mv = M v and md = M d in one pass, M = blocks ms(k) I on the block
    !> pattern of kb (see block3_scalar_blocks); K x stored twice (kx and bx), as
    !> block2_matvec_ks3. kx is bitwise equal to block3_matvec's.
    pure subroutine block3_matvec_ks3(kb, ms, x, v, d, kx, mv, md, bx)
        type(block3_t), intent(in) :: kb                   !! K (every group a triple)
        real(dp), intent(in) :: ms(size(kb%col1))          !! (n_blocks) scalar blocks of M
        real(dp), intent(in) :: x(kb%n)                    !! (n) vector multiplied by K
        real(dp), intent(in) :: v(kb%n)                    !! (n) first vector multiplied by M
        real(dp), intent(in) :: d(kb%n)                    !! (n) second vector multiplied by M
        real(dp), intent(out) :: kx(kb%n)                  !! (n) K x
        real(dp), intent(out) :: mv(kb%n)                  !! (n) M v
        real(dp), intent(out) :: md(kb%n)                  !! (n) M d
        real(dp), intent(out) :: bx(kb%n)                  !! (n) K x again
        call ks3_rows3(kb%n, kb%n_groups, size(kb%col1), kb%row_ptr, kb%col1, kb%first, kb%val, &
                       ms, x, v, d, kx, mv, md, bx)
    end subroutine block3_matvec_ks3

    !> block3_matvec_ks3 on the arrays of K (explicit shapes, see pairs_rows).
    pure subroutine ks3_rows3(n, ng, nb, row_ptr, col1, first, val, ms, x, v, d, kx, mv, md, bx)
        integer, intent(in) :: n, ng, nb                   !! size, groups, blocks
        integer, intent(in) :: row_ptr(ng + 1)             !! block range of each row group
        integer, intent(in) :: col1(nb)                    !! first dof of each block's column group
        integer, intent(in) :: first(ng + 1)               !! first dof of each group
        real(dp), intent(in) :: val(9 * nb + 9)             !! blocks of K (and the zero block)
        real(dp), intent(in) :: ms(nb)                     !! scalar blocks of M
        real(dp), intent(in) :: x(n), v(n), d(n)           !! vectors
        real(dp), intent(out) :: kx(n), mv(n), md(n)       !! K x, M v, M d
        real(dp), intent(out) :: bx(n)                     !! K x again
        integer :: g, k, c, i, o
        real(dp) :: y(4), p(3), q(3)
        do g = 1, ng
            y = 0.0_dp
            p = 0.0_dp
            q = 0.0_dp
            do k = row_ptr(g), row_ptr(g + 1) - 1
                c = col1(k)
                o = 9 * (k - 1)
                y = y + val(o + 1:o + 4) * x(c) + val(o + 4:o + 7) * x(c + 1) &
                    + val(o + 7:o + 10) * x(c + 2)
                p = p + ms(k) * v(c:c + 2)
                q = q + ms(k) * d(c:c + 2)
            end do
            i = first(g)
            kx(i:i + 2) = y(1:3)
            bx(i:i + 2) = y(1:3)
            mv(i:i + 2) = p
            md(i:i + 2) = q
        end do
    end subroutine ks3_rows3

    !> b = a without its stored zeros (|a_ij| == 0). Optional stat reports an
    !> allocation failure (STAT_INTERNAL); b is then empty.
    pure subroutine csc_drop_zeros(a, b, stat, errmsg)
        type(csc_t), intent(in) :: a                        !! matrix
        type(csc_t), intent(out) :: b                       !! compacted copy
        integer, intent(out), optional :: stat              !! status (STAT_OK, STAT_INTERNAL)
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: j, k, m, ierr, st
        logical :: filled
        st = STAT_OK
        filled = a%n > 0 .and. allocated(a%colptr) .and. allocated(a%rowind) &
                 .and. allocated(a%val)
        m = 0
        if (filled) m = count(.not. is_zero(a%val(1:a%nnz)))
        b%n = max(a%n, 0)
        allocate (b%colptr(b%n + 1), b%rowind(m), b%val(m), stat=ierr)
        if (ierr /= 0) then
            b%n = 0
            call raise(st, errmsg, STAT_INTERNAL, 'csc_drop_zeros: out of memory')
            if (present(stat)) stat = st
            return
        end if
        b%colptr = 0
        m = 0
        if (filled) then
            do j = 1, a%n
                do k = a%colptr(j) + 1, a%colptr(j + 1)
                    if (.not. is_zero(a%val(k))) then
                        m = m + 1
                        b%rowind(m) = a%rowind(k)
                        b%val(m) = a%val(k)
                    end if
                end do
                b%colptr(j + 1) = int(m, c_int)
            end do
        end if
        b%nnz = m
        if (present(stat)) stat = st
    end subroutine csc_drop_zeros

    !> True for +0 and -0 (false for NaN, which is kept as a stored value).
    elemental function is_zero(v) result(z)
        real(dp), intent(in) :: v   !! value
        logical :: z
        z = abs(v) <= 0.0_dp
    end function is_zero
end module sparse
