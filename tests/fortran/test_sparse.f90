!> Unit tests of module sparse: COO -> CSC (sorting, duplicates, explicit zeros,
!> bad indices), csc_find, matvec kernels against a dense product, drop_zeros,
!> same-pattern value updates, the fused node-block products, the CSC values read back from
!> block copies. Exit status 1 (error stop) on any failure.
program test_sparse
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, MSG_LEN
    use sparse, only: csc_t, csc_from_coo, csc_find, csc_matvec, csc_matvec_t, &
                      csc_drop_zeros, block2_t, block2_from_csc, block2_matvec, &
                      block2_matvec_km, block2_scalar_blocks, block2_matvec_ks2, block2_matvec_ks3, &
                      block2_csc_values, block3_t, block3_from_csc, block3_csc_values, &
                      block3_scalar_blocks
    use unit_checks, only: checks_t, seed
    implicit none

    real(dp), parameter :: thr = 100 * epsilon(1.0_dp)   ! algebraic identities (relative)
    type(checks_t) :: checks

    call test_small_exact()
    call test_bad_input()
    call test_empty()
    call test_random_against_dense()
    call test_drop_zeros()
    call test_block2()
    call test_block2_fused()
    call test_scalar_blocks(2)
    call test_scalar_blocks(3)

    call checks%finish('test_sparse')

contains


    !> 3 x 3, unsorted, duplicates, an explicit zero, an empty column.
    subroutine test_small_exact()
        type(csc_t) :: a
        integer :: stat
        character(len=MSG_LEN) :: msg
        ! entries: (3,1)=1 (1,1)=2 (3,1)+=4 (2,3)=0 (1,3)=5 (3,3)=-1 (1,1)+=0.5
        integer, parameter :: r(7) = [3, 1, 3, 2, 1, 3, 1]
        integer, parameter :: c(7) = [1, 1, 1, 3, 3, 3, 1]
        real(dp), parameter :: v(7) = [1.0_dp, 2.0_dp, 4.0_dp, 0.0_dp, 5.0_dp, -1.0_dp, 0.5_dp]
        msg = ''
        call csc_from_coo(3, r, c, v, a, stat, msg)
        call checks%check(stat == STAT_OK, 'small: stat ok')
        call checks%check(a%n == 3 .and. a%nnz == 5, 'small: n, nnz')
        call checks%check(all(a%colptr == [0, 2, 2, 5]), 'small: colptr')
        call checks%check(all(a%rowind == [0, 2, 0, 1, 2]), 'small: rowind sorted')
        call checks%check(all(abs(a%val - [2.5_dp, 5.0_dp, 5.0_dp, 0.0_dp, -1.0_dp]) <= thr), &
                   'small: values summed, zero kept')
        call checks%check(csc_find(a, 1, 1) == 1 .and. csc_find(a, 3, 1) == 2, 'small: find col 1')
        call checks%check(csc_find(a, 2, 3) == 4 .and. csc_find(a, 3, 3) == 5, 'small: find col 3')
        call checks%check(csc_find(a, 2, 1) == 0 .and. csc_find(a, 1, 2) == 0, 'small: find misses')
        call checks%check(csc_find(a, 0, 1) == 0 .and. csc_find(a, 1, 4) == 0, 'small: find out of range')
    end subroutine test_small_exact

    subroutine test_bad_input()
        type(csc_t) :: a
        integer :: stat
        character(len=MSG_LEN) :: msg
        msg = ''
        call csc_from_coo(2, [1, 3], [1, 1], [1.0_dp, 1.0_dp], a, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: row 3 > n')
        call checks%check(index(msg, 'out of range') > 0, 'bad: message names range: '//trim(msg))
        call csc_from_coo(2, [1, 1], [0, 1], [1.0_dp, 1.0_dp], a, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: column 0')
        call csc_from_coo(2, [1, 1], [1, 1], [1.0_dp], a, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: length mismatch')
        call csc_from_coo(-1, [integer ::], [integer ::], [real(dp) ::], a, stat)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: negative n')
    end subroutine test_bad_input

    subroutine test_empty()
        type(csc_t) :: a, b
        integer :: stat
        real(dp) :: x(3), y(3)
        call csc_from_coo(0, [integer ::], [integer ::], [real(dp) ::], a, stat)
        call checks%check(stat == STAT_OK .and. a%n == 0 .and. a%nnz == 0, 'empty: n = 0')
        call checks%check(size(a%colptr) == 1, 'empty: colptr(1)')
        call csc_from_coo(3, [integer ::], [integer ::], [real(dp) ::], a, stat)
        call checks%check(stat == STAT_OK .and. all(a%colptr == 0), 'empty: zero matrix 3x3')
        x = 1.0_dp
        call csc_matvec(a, x, y)
        call checks%check(all(abs(y) <= 0.0_dp), 'empty: matvec zero')
        call csc_drop_zeros(a, b, stat)
        call checks%check(stat == STAT_OK .and. b%n == 3 .and. b%nnz == 0, 'empty: drop_zeros')
    end subroutine test_empty

    !> Random unsorted COO with many duplicates: CSC kernels equal dense algebra.
    subroutine test_random_against_dense()
        integer, parameter :: sizes(4) = [1, 7, 50, 200]
        integer :: t, n, m, k, stat, j, p
        integer, allocatable :: r(:), c(:)
        real(dp), allocatable :: v(:), u(:), dense(:, :), x(:), y(:), yd(:)
        real(dp) :: scale
        type(csc_t) :: a
        logical :: sorted
        call seed(12345)
        do t = 1, size(sizes)
            n = sizes(t)
            m = 4 * n + 3
            allocate (r(m), c(m), v(m), u(m), dense(n, n), x(n), y(n), yd(n))
            call random_number(u)
            r = 1 + int(u * n)
            call random_number(u)
            c = 1 + int(u * n)
            r(m) = r(1)            ! guaranteed duplicates
            c(m) = c(1)
            call random_number(v)
            v = v - 0.5_dp
            dense = 0.0_dp
            do k = 1, m
                dense(r(k), c(k)) = dense(r(k), c(k)) + v(k)
            end do
            call csc_from_coo(n, r, c, v, a, stat)
            call checks%check(stat == STAT_OK, 'random: stat')
            sorted = .true.
            do j = 1, n
                do p = a%colptr(j) + 2, a%colptr(j + 1)
                    if (a%rowind(p) <= a%rowind(p - 1)) sorted = .false.
                end do
            end do
            call checks%check(sorted, 'random: rows strictly increasing in each column')
            call checks%check(a%nnz == count_distinct(n, r, c), 'random: nnz = distinct positions')
            do k = 1, m
                p = csc_find(a, r(k), c(k))
                if (p == 0) then
                    call checks%check(.false., 'random: stored entry found')
                    exit
                end if
                if (abs(a%val(p) - dense(r(k), c(k))) > thr) then
                    call checks%check(.false., 'random: summed value')
                    exit
                end if
            end do
            call random_number(x)
            x = 2 * x - 1
            yd = matmul(dense, x)
            scale = max(1.0_dp, maxval(abs(yd)))
            call csc_matvec(a, x, y)
            call checks%check(maxval(abs(y - yd)) <= thr * scale, 'random: matvec')
            yd = matmul(transpose(dense), x)
            call csc_matvec_t(a, x, y)
            call checks%check(maxval(abs(y - yd)) <= thr * max(1.0_dp, maxval(abs(yd))), &
                       'random: transposed matvec')
            deallocate (r, c, v, u, dense, x, y, yd)
        end do
    end subroutine test_random_against_dense

    subroutine test_drop_zeros()
        type(csc_t) :: a, b
        integer :: stat
        real(dp) :: x(3), ya(3), yb(3)
        call csc_from_coo(3, [1, 2, 3, 1, 3], [1, 1, 2, 3, 3], &
                          [1.0_dp, 0.0_dp, 2.0_dp, -0.0_dp, 3.0_dp], a, stat)
        call checks%check(stat == STAT_OK .and. a%nnz == 5, 'drop: built with zeros')
        call csc_drop_zeros(a, b, stat)
        call checks%check(stat == STAT_OK, 'drop: stat')
        call checks%check(b%n == 3 .and. b%nnz == 3, 'drop: nnz')
        call checks%check(all(b%colptr == [0, 1, 2, 3]), 'drop: colptr')
        call checks%check(all(b%rowind == [0, 2, 2]), 'drop: rowind')
        x = [1.0_dp, 2.0_dp, 3.0_dp]
        call csc_matvec(a, x, ya)
        call csc_matvec(b, x, yb)
        call checks%check(all(abs(ya - yb) <= 0.0_dp), 'drop: same product')
        call csc_drop_zeros(a, b)      ! stat is optional
        call checks%check(b%nnz == 3, 'drop: without stat')
    end subroutine test_drop_zeros

    !> Node-block products of random symmetric matrices against dense ones, with
    !> groups of one and two dofs mixed (nodes with one constrained component).
    subroutine test_block2()
        integer, parameter :: ng = 40
        integer :: sizes(ng), first(ng + 1), n, m, k, stat, g
        integer, allocatable :: r(:), c(:)
        real(dp), allocatable :: v(:), u(:), dense(:, :), x(:), y(:), yd(:)
        type(csc_t) :: a
        type(block2_t) :: b
        call seed(4242)
        allocate (u(ng))
        call random_number(u)
        sizes = merge(1, 2, u < 0.3_dp)
        first(1) = 1
        do g = 1, ng
            first(g + 1) = first(g) + sizes(g)
        end do
        n = first(ng + 1) - 1
        m = 5 * n
        deallocate (u)
        allocate (r(2 * m), c(2 * m), v(2 * m), u(m), dense(n, n), x(n), y(n), yd(n))
        call random_number(u)
        r(1:m) = 1 + int(u * n)
        call random_number(u)
        c(1:m) = 1 + int(u * n)
        call random_number(v(1:m))
        r(m + 1:) = c(1:m)          ! mirror: symmetric
        c(m + 1:) = r(1:m)
        v(m + 1:) = v(1:m)
        dense = 0.0_dp
        do k = 1, 2 * m
            dense(r(k), c(k)) = dense(r(k), c(k)) + v(k)
        end do
        call csc_from_coo(n, r, c, v, a, stat)
        call checks%check(stat == STAT_OK, 'block2: coo')
        call block2_from_csc(a, first, b, stat)
        call checks%check(stat == STAT_OK, 'block2: build')
        call random_number(x)
        yd = matmul(dense, x)
        call block2_matvec(b, x, y)
        call checks%check(maxval(abs(y - yd)) <= thr * max(1.0_dp, maxval(abs(yd))), 'block2: matvec')
        ! the CSC values read back from the blocks: the same numbers, entry by entry
        call block2_csc_values(a, b, v(1:a%nnz))
        call checks%check(all(v(1:a%nnz) == a%val), 'block2: CSC values read back bitwise')
        call check_block3_values(a)
        call block2_from_csc(a, [1, 4, n + 1], b, stat)
        call checks%check(stat == STAT_BAD_INPUT, 'block2: a group of 3 dofs is refused')
    end subroutine test_block2

    !> block2_scalar_blocks / block3_scalar_blocks (w = 2, 3) on S (x) I_w, two nodes, S a
    !> symmetric 2 x 2 of nonzero entries: scalar blocks found, the scalars S's entries in
    !> block order; then a value off the diagonal of a block, or one diagonal entry
    !> changed, makes the form fail.
    subroutine test_scalar_blocks(w)
        integer, intent(in) :: w                     !! node block width
        real(dp), parameter :: sm(2, 2) = reshape([4.0_dp, -1.0_dp, -1.0_dp, 3.0_dp], [2, 2])
        integer :: r(4 * w * w), c(4 * w * w), n, k, i, j, p, q, stat, variant
        real(dp) :: v(4 * w * w)
        real(dp), allocatable :: s(:)
        type(csc_t) :: a
        type(block2_t) :: b2
        type(block3_t) :: b3
        character(len=16) :: what
        logical :: ok
        n = 2 * w
        write (what, '(a, i0, a)') 'scalar blocks ', w, ':'
        do variant = 0, 2
            k = 0
            do j = 1, n
                do i = 1, n
                    k = k + 1
                    p = (i - 1) / w + 1
                    q = (j - 1) / w + 1
                    r(k) = i
                    c(k) = j
                    v(k) = 0.0_dp
                    if (mod(i - 1, w) == mod(j - 1, w)) v(k) = sm(p, q)
                    ! variant 1: a12 = a21 = 0.5 in the first diagonal block
                    if (variant == 1 .and. ((i == 1 .and. j == 2) .or. (i == 2 .and. j == 1))) &
                        v(k) = 0.5_dp
                    ! variant 2: the last diagonal entry of the first block changed
                    if (variant == 2 .and. i == w .and. j == w) v(k) = 5.0_dp
                end do
            end do
            call csc_from_coo(n, r, c, v, a, stat)
            if (w == 2) then
                call block2_from_csc(a, [1, 3, 5], b2, stat)
                call block2_scalar_blocks(b2, s, ok)
            else
                call block3_from_csc(a, [1, 4, 7], b3, stat)
                call block3_scalar_blocks(b3, s, ok)
            end if
            call checks%check(stat == STAT_OK, trim(what)//' build')
            if (variant == 0) then
                call checks%check(ok .and. size(s) == 4, trim(what)//' S (x) I found')
                if (ok .and. size(s) == 4) &
                    call checks%check(all(s == [sm(1, 1), sm(2, 1), sm(1, 2), sm(2, 2)]), &
                                      trim(what)//' the scalars are S''s entries')
            else
                call checks%check(.not. ok .and. size(s) == 0, trim(what)//' a non-scalar block refused')
            end if
        end do
    end subroutine test_scalar_blocks

    !> block3_csc_values gives back a's values bitwise (groups of one to three dofs).
    subroutine check_block3_values(a)
        type(csc_t), intent(in) :: a        !! symmetric matrix
        type(block3_t) :: b3
        integer, allocatable :: first(:)
        real(dp), allocatable :: val(:)
        integer :: g, stat
        allocate (first(a%n + 1), val(a%nnz))
        first(1) = 1
        g = 1
        do while (first(g) <= a%n)          ! groups of 3, 1, 2, 3, 1, 2, ... (the last cut at n)
            first(g + 1) = min(a%n + 1, first(g) + 1 + mod(g + 1, 3))
            g = g + 1
        end do
        call block3_from_csc(a, first(1:g), b3, stat)
        call checks%check(stat == STAT_OK .and. .not. b3%triples, 'block3: build (mixed groups)')
        call block3_csc_values(a, b3, val)
        call checks%check(all(val == a%val), 'block3: CSC values read back bitwise')
    end subroutine check_block3_values

    !> The fused node-block products (K x with one or two M products) against dense
    !> products, on random symmetric K and M sharing one pattern; K x must be bitwise
    !> equal to block2_matvec's (the kernels promise the same per-row order).
    !> km runs on mixed groups of one and two dofs; ks2/ks3 on pairs with M = s I blocks.
    subroutine test_block2_fused()
        integer, parameter :: ng = 40, m = 3 * ng
        integer :: sizes(ng), first(ng + 1), n, k, nt, stat, g, h, i, j, t
        integer :: r(8 * m), c(8 * m)
        real(dp) :: kv(8 * m), mv_(8 * m), u(2 * m), sb(ng, ng), kval, mval
        real(dp), allocatable :: kd(:, :), md_(:, :), x(:), v(:), d(:), kx(:), mv(:), md(:), &
                                 kx0(:), s(:), bx(:)
        type(csc_t) :: ka, ma
        type(block2_t) :: kb, mb
        logical :: scal, pairs
        call seed(777)
        do t = 1, 2
            pairs = t == 2
            call random_number(u(1:ng))
            sizes = merge(1, 2, u(1:ng) < 0.3_dp .and. .not. pairs)
            first(1) = 1
            do g = 1, ng
                first(g + 1) = first(g) + sizes(g)
            end do
            n = first(ng + 1) - 1
            call random_number(sb)
            sb = sb + transpose(sb)
            ! m random block positions (g, h) and their mirrors, all entries of each block
            call random_number(u)
            nt = 0
            do k = 1, m
                g = 1 + int(u(k) * ng)
                h = 1 + int(u(m + k) * ng)
                do i = first(g), first(g + 1) - 1
                    do j = first(h), first(h + 1) - 1
                        if (pairs) then   ! M block = sb(g, h) I
                            mval = sb(g, h) * merge(1.0_dp, 0.0_dp, i - first(g) == j - first(h))
                        else
                            call random_number(mval)
                        end if
                        call random_number(kval)
                        r(nt + 1:nt + 2) = [i, j]
                        c(nt + 1:nt + 2) = [j, i]
                        kv(nt + 1:nt + 2) = kval
                        mv_(nt + 1:nt + 2) = mval
                        nt = nt + 2
                    end do
                end do
            end do
            allocate (kd(n, n), md_(n, n), x(n), v(n), d(n), kx(n), mv(n), md(n), kx0(n), bx(n))
            kd = 0.0_dp
            md_ = 0.0_dp
            do k = 1, nt
                kd(r(k), c(k)) = kd(r(k), c(k)) + kv(k)
                md_(r(k), c(k)) = md_(r(k), c(k)) + mv_(k)
            end do
            call csc_from_coo(n, r(1:nt), c(1:nt), kv(1:nt), ka, stat)
            call checks%check(stat == STAT_OK, 'block2 fused: coo K')
            call csc_from_coo(n, r(1:nt), c(1:nt), mv_(1:nt), ma, stat)
            call checks%check(stat == STAT_OK, 'block2 fused: coo M')
            call block2_from_csc(ka, first, kb, stat)
            call checks%check(stat == STAT_OK, 'block2 fused: build K')
            call block2_from_csc(ma, first, mb, stat)
            call checks%check(stat == STAT_OK, 'block2 fused: build M')
            call random_number(x)
            call random_number(v)
            call random_number(d)
            x = x - 0.5_dp
            call block2_matvec(kb, x, kx0)
            call block2_scalar_blocks(mb, s, scal)
            call checks%check(scal .eqv. pairs, 'block2 fused: scalar blocks found iff all pairs')
            call block2_matvec_km(kb, mb, x, v, d, kx, mv, md)
            call check_fused('km', kd, md_, x, v, kx0, kx, mv, d, md)
            if (pairs .and. scal) then
                call block2_matvec_ks3(kb, s, x, v, d, kx, mv, md, bx)
                call check_fused('ks3', kd, md_, x, v, kx0, kx, mv, d, md)
                call checks%check(all(bx == kx), 'block2 fused: ks3 K x written twice, equal')
                call block2_matvec_ks2(kb, s, x, v, kx, mv)
                call check_fused('ks2', kd, md_, x, v, kx0, kx, mv)
            end if
            deallocate (kd, md_, x, v, d, kx, mv, md, kx0, bx)
        end do
    end subroutine test_block2_fused

    !> A fused product against dense ones: kx bitwise equal to block2_matvec's kx0,
    !> kx = K x, mv = M v and (when given) md = M d to thr.
    subroutine check_fused(what, kd, md_, x, v, kx0, kx, mv, d, md)
        character(len=*), intent(in) :: what           !! kernel name
        real(dp), intent(in) :: kd(:, :)               !! dense K
        real(dp), intent(in) :: md_(:, :)              !! dense M
        real(dp), intent(in) :: x(:)                   !! vector multiplied by K
        real(dp), intent(in) :: v(:)                   !! vector multiplied by M
        real(dp), intent(in) :: kx0(:)                 !! block2_matvec's K x
        real(dp), intent(in) :: kx(:)                  !! the kernel's K x
        real(dp), intent(in) :: mv(:)                  !! the kernel's M v
        real(dp), intent(in), optional :: d(:)         !! second vector multiplied by M
        real(dp), intent(in), optional :: md(:)        !! the kernel's M d
        real(dp) :: yd(size(x))
        call checks%check(all(kx == kx0), 'block2 fused: '//what//' K x bitwise = block2_matvec')
        yd = matmul(kd, x)
        call checks%check(maxval(abs(kx - yd)) <= thr * max(1.0_dp, maxval(abs(yd))), &
                          'block2 fused: '//what//' K x')
        yd = matmul(md_, v)
        call checks%check(maxval(abs(mv - yd)) <= thr * max(1.0_dp, maxval(abs(yd))), &
                          'block2 fused: '//what//' M v')
        if (.not. (present(d) .and. present(md))) return
        yd = matmul(md_, d)
        call checks%check(maxval(abs(md - yd)) <= thr * max(1.0_dp, maxval(abs(yd))), &
                          'block2 fused: '//what//' M d')
    end subroutine check_fused

    !> Number of distinct (r, c) positions.
    function count_distinct(n, r, c) result(cnt)
        integer, intent(in) :: n        !! size
        integer, intent(in) :: r(:)     !! rows
        integer, intent(in) :: c(:)     !! columns
        integer :: cnt
        logical, allocatable :: seen(:, :)
        integer :: k
        allocate (seen(n, n))
        seen = .false.
        do k = 1, size(r)
            seen(r(k), c(k)) = .true.
        end do
        cnt = count(seen)
    end function count_distinct
end program test_sparse
