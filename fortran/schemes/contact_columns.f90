!> The columns of Z = J0^{-1} P^T and W = P Z (P restricts to the m contact-cell dofs)
!> that the implicit schemes' contact correction uses, computed when a contact-cell dof
!> first needs them (its cell has an active contact point) and kept in a cache, so that
!> memory grows with n x (dofs recently active), not n x (all contact-cell dofs).
!>
!> Columns are solved with J0 by fixed groups of ZCHUNK (group g: columns ZCHUNK (g-1) + 1
!> to ZCHUNK g), one ls_solve_many call a group, the group whole whenever one of its
!> columns is needed: a multi-column solve (CHOLMOD's cholmod_solve2) need not give a
!> column the bits of a solve with other columns beside it, so each column is always
!> solved beside the same ones, and its numbers do not depend on when it is computed
!> (the same calls as a precomputation of all of Z by groups). The group is also the
!> unit the cache keeps and drops. W(:, l) = Z(cdofs, l) is kept whole (m entries); Z(:, l) is
!> kept as row indices and values, on every row when the whole of Z (8 n m bytes) is
!> within the budget the scheme gives (the small meshes: the same numbers as a dense
!> Z), else on the rows where its magnitude exceeds ZDROP times the column's largest
!> (J0^{-1} decays geometrically away from the dof; the part dropped is below 1e-20 of
!> the column, far under round-off). Either way a column's kept rows depend on the
!> column alone. (Without dropping, Z's columns are kept as n values, without rows.)
!>
!> The cache holds at most `budget` bytes besides the groups used at the current step:
!> when it exceeds it, the groups least recently used (before the current step) are
!> dropped, and computed again, to the same numbers, if needed again. A checkpoint keeps
!> the cache's layout, not its numbers (zcache_save: the groups held and the step each was
!> last needed, the basis columns' slots, the counters; a few integers a group): a
!> restarted run solves the groups held again before its first step (zcache_restore, to
!> the same bits) and then holds, drops and solves what the run never stopped does.
!>
!> Besides the columns of Z, the cache can hold combined columns Z b_k = sum_e c_e Z(:, l_e)
!> of fixed vectors b_k on the contact-cell dofs (the implicit schemes' node basis: a
!> facet's sigma_n row, a node's normal), formed from Z's columns when first needed and
!> kept (zcache_basis_init, zcache_basis_ensure, zcache_add_basis): Z T for a T given by
!> its coefficients on those vectors then reads one column a vector instead of one a dof.
!> Each is applied on the rows from its first to its last entry above ZDROP times its
!> largest magnitude (one contiguous range: J0^{-1} decays away from the contact, and the
!> rows near the contact come first in the box's and the bar's numbering; at h = 0.025 the
!> box's ranges end near row 2 100 of 3 000). Only where Z is kept whole (never dropped
!> rows). They count in the bytes held, and when the columns of Z of earlier steps are
!> all dropped and the cache still exceeds its budget, the b_k least recently used
!> (before the current step) are dropped too, and formed again, from the same columns of
!> Z by the same sums, to the same numbers, if needed again.
module contact_columns
    use kinds, only: dp, i8
    use errors, only: STAT_OK, STAT_INTERNAL, raise, oom_text, is_oom_text, mb_text, OOM_HINT_MESH
    use byte_buffer, only: byte_buffer_t, buf_put, buf_get
    use stop_signal, only: check_stop
    use sparse, only: csc_t
    use linear_solver, only: factor_t, ls_solve_many
    implicit none
    private

    !> Entries of a column of Z at most ZDROP times its largest magnitude are dropped.
    real(dp), parameter, public :: ZDROP = 1.0e-20_dp
    !> Columns of a group (solved in one call).
    integer, parameter, public :: ZCHUNK = 16

    !> One column of Z on its kept rows.
    type :: zcol_t
        integer, allocatable :: rows(:)           !! rows kept, ascending (none: all n)
        real(dp), allocatable :: val(:)           !! Z there
    end type zcol_t

    !> The cache of columns of Z and W.
    type, public :: zcache_t
        integer :: n = 0                          !! dofs
        integer :: m = 0                          !! contact-cell dofs (columns)
        integer(i8) :: budget = 0                 !! bytes kept beyond the current step's columns
        logical :: drop = .false.                 !! Z's entries below ZDROP max|Z(:, l)| dropped
        integer(i8) :: bytes = 0                  !! bytes of the columns held
        integer(i8) :: peak_bytes = 0             !! the largest `bytes` so far
        integer :: step = 0                       !! current step (zcache_new_step)
        integer :: held = 0                       !! columns held
        integer :: computed = 0                   !! columns solved (recomputations included)
        integer :: evicted = 0                    !! columns dropped by the budget
        integer, allocatable :: slot(:)           !! (m) where column l is held, 0: not held
        integer, allocatable :: owner(:)          !! (cap) column held in a slot, 0: free
        integer, allocatable :: glast(:)          !! (groups) the step that last needed the
                                                  !! group, -1: not held
        real(dp), allocatable :: w(:, :)          !! (m, cap) W(:, owner)
        type(zcol_t), allocatable :: z(:)         !! (cap) Z(:, owner) on its kept rows
        integer, allocatable :: pending(:)        !! (m) columns to solve (work)
        integer, allocatable :: bslot(:)          !! (basis vectors) where Z b_k is held, 0: not
        real(dp), allocatable :: zb(:, :)         !! (n, bcap) Z b_k (column bslot(k))
        integer, allocatable :: brange(:, :)      !! (2, bcap) its rows applied (first, last)
        integer, allocatable :: bowner(:)         !! (bcap) basis vector held in a slot, 0: free
        integer, allocatable :: blast(:)          !! (basis vectors) the step that last needed it
        logical :: restore_due = .false.          !! a checkpoint's layout waits for zcache_restore
        integer, allocatable :: restore_glast(:)  !! (groups) its glast
        integer, allocatable :: restore_bowner(:) !! (its basis slots) its bowner
        integer :: restore_computed = 0           !! its computed
        integer :: restore_evicted = 0            !! its evicted
        integer(i8) :: restore_peak = 0           !! its peak_bytes
    end type zcache_t

    public :: zcache_init, zcache_new_step, zcache_ensure, zcache_ensure_all, zcache_w_times, &
              zcache_add_w, zcache_add_z, zcache_free, zcache_basis_init, zcache_basis_ensure, &
              zcache_add_basis, zcache_save, zcache_load, zcache_restore, zcache_basis_reform, &
              zcache_restore_finish

contains

    !> An empty cache for n dofs and m contact-cell dofs, with a budget in bytes; Z's
    !> tiny entries are dropped when 8 n m bytes exceed drop_above (see the module header).
    pure subroutine zcache_init(zc, n, m, budget, drop_above)
        type(zcache_t), intent(out) :: zc            !! cache
        integer, intent(in) :: n, m                  !! dofs, contact-cell dofs
        integer(i8), intent(in) :: budget            !! bytes (see the module header)
        integer(i8), intent(in) :: drop_above        !! bytes of a whole Z kept whole
        zc%n = n
        zc%m = m
        zc%budget = max(0_i8, budget)
        zc%drop = 8_i8 * n * m > drop_above
        allocate (zc%slot(m), zc%pending(m), zc%owner(0), zc%w(m, 0), zc%z(0), &
                  zc%glast((m + ZCHUNK - 1) / ZCHUNK))
        zc%slot = 0
        zc%glast = -1
    end subroutine zcache_init

    !> Release every column (the counters are kept).
    pure subroutine zcache_free(zc)
        type(zcache_t), intent(inout) :: zc          !! cache
        if (allocated(zc%slot)) zc%slot = 0
        if (allocated(zc%glast)) zc%glast = -1
        if (allocated(zc%owner)) deallocate (zc%owner, zc%w, zc%z)
        allocate (zc%owner(0), zc%w(zc%m, 0), zc%z(0))
        zc%bytes = 0
        zc%held = 0
        if (allocated(zc%bslot)) then
            zc%bslot = 0
            zc%blast = -1
            deallocate (zc%zb, zc%brange, zc%bowner)
            allocate (zc%zb(zc%n, 0), zc%brange(2, 0), zc%bowner(0))
        end if
    end subroutine zcache_free

    !> Room for nb combined columns Z b_k (none held); Z must be kept whole (not drop).
    pure subroutine zcache_basis_init(zc, nb)
        type(zcache_t), intent(inout) :: zc          !! cache
        integer, intent(in) :: nb                    !! basis vectors
        if (allocated(zc%bslot)) deallocate (zc%bslot, zc%zb, zc%brange, zc%bowner, zc%blast)
        allocate (zc%bslot(nb), zc%zb(zc%n, 0), zc%brange(2, 0), zc%bowner(0), zc%blast(nb))
        zc%bslot = 0
        zc%blast = -1
    end subroutine zcache_basis_init

    !> Make Z b_k = sum_e coef(e) Z(:, cols(e)) (e in order, cols(e) > 0 only) available
    !> and mark it used at the current step, solving the columns of Z it needs if they are
    !> not held; then drop what the budget asks for (see the module header).
    subroutine zcache_basis_ensure(zc, lu, a, val, cdofs, k, cols, coef, stat, errmsg)
        type(zcache_t), intent(inout) :: zc          !! cache (zcache_basis_init done)
        type(factor_t), intent(inout) :: lu          !! factors of J0
        type(csc_t), intent(in) :: a                 !! the pattern of J0 (the model's)
        real(dp), intent(in) :: val(:)               !! (a%nnz) J0's values on it
        integer, intent(in) :: cdofs(:)              !! (m) the contact-cell dofs
        integer, intent(in) :: k                     !! basis vector
        integer, intent(in) :: cols(:)               !! its contact-cell dofs (<= 0: none)
        real(dp), intent(in) :: coef(:)              !! and its entries there
        integer, intent(out) :: stat                 !! status (of the solves)
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), allocatable :: tmp(:, :)
        integer, allocatable :: itmp(:, :), otmp(:)
        integer :: s, cap, ncap
        stat = STAT_OK
        zc%blast(k) = zc%step
        if (zc%bslot(k) > 0) return
        call zcache_ensure(zc, lu, a, val, cdofs, cols, stat, errmsg)
        if (stat /= STAT_OK) return
        cap = size(zc%bowner)
        s = findloc(zc%bowner, 0, dim=1)
        if (s == 0) then      ! (the slot arrays doubled when full)
            ncap = min(size(zc%bslot), max(2 * cap, ZCHUNK))
            allocate (tmp(zc%n, ncap), itmp(2, ncap), otmp(ncap), stat=s)
            if (s /= 0) then
                call columns_oom(zc, 8.0_dp * zc%n * ncap, stat, errmsg)
                return
            end if
            tmp(:, 1:cap) = zc%zb
            itmp(:, 1:cap) = zc%brange
            otmp = 0
            otmp(1:cap) = zc%bowner
            call move_alloc(tmp, zc%zb)
            call move_alloc(itmp, zc%brange)
            call move_alloc(otmp, zc%bowner)
            s = cap + 1
        end if
        zc%bowner(s) = k
        call zcache_basis_form(zc, s, cols, coef)
        zc%bslot(k) = s
        zc%bytes = zc%bytes + 8_i8 * zc%n
        zc%peak_bytes = max(zc%peak_bytes, zc%bytes)
        call evict(zc)
    end subroutine zcache_basis_ensure

    !> Form Z b_k = sum_e coef(e) Z(:, cols(e)) (e in order, cols(e) > 0 only) in basis
    !> slot s and the range of its rows applied; the columns of Z it reads must be held.
    pure subroutine zcache_basis_form(zc, s, cols, coef)
        type(zcache_t), intent(inout) :: zc          !! cache
        integer, intent(in) :: s                     !! basis slot
        integer, intent(in) :: cols(:)               !! the vector's contact-cell dofs (<= 0: none)
        real(dp), intent(in) :: coef(:)              !! and its entries there
        real(dp) :: cmax
        integer :: e, i
        zc%zb(:, s) = 0.0_dp
        do e = 1, size(cols)
            if (cols(e) <= 0) cycle
            call add1(zc%n, zc%z(zc%slot(cols(e)))%val, coef(e), zc%zb(:, s))
        end do
        ! the rows applied: from the first to the last entry above ZDROP of the largest
        cmax = ZDROP * maxval(abs(zc%zb(:, s)))
        zc%brange(:, s) = [1, 0]
        do i = 1, zc%n
            if (abs(zc%zb(i, s)) > cmax) then
                zc%brange(1, s) = i
                exit
            end if
        end do
        do i = zc%n, zc%brange(1, s), -1
            if (abs(zc%zb(i, s)) > cmax) then
                zc%brange(2, s) = i
                exit
            end if
        end do
    end subroutine zcache_basis_form

    !> Append the cache's layout to a checkpoint (see the module header): the step, the
    !> counters, glast, and the basis columns' slots and steps.
    pure subroutine zcache_save(zc, buf)
        type(zcache_t), intent(in) :: zc             !! cache
        type(byte_buffer_t), intent(inout) :: buf    !! checkpoint payload
        call buf_put(buf, int(zc%step, i8))
        call buf_put(buf, int(zc%computed, i8))
        call buf_put(buf, int(zc%evicted, i8))
        call buf_put(buf, zc%peak_bytes)
        call buf_put(buf, zc%glast)
        if (allocated(zc%bslot)) then
            call buf_put(buf, int(size(zc%bowner), i8))
            call buf_put(buf, zc%bowner)
            call buf_put(buf, zc%blast)
        else
            call buf_put(buf, -1_i8)
        end if
    end subroutine zcache_save

    !> Read what zcache_save wrote (buf%bad on a mismatch): the cache is emptied, takes
    !> the step and counters, and keeps the layout for zcache_restore.
    pure subroutine zcache_load(zc, buf)
        type(zcache_t), intent(inout) :: zc          !! cache (zcache_init and basis_init done)
        type(byte_buffer_t), intent(inout) :: buf    !! checkpoint payload
        integer(i8) :: k(4), cap
        integer :: j
        call zcache_free(zc)
        zc%restore_due = .false.
        if (allocated(zc%restore_bowner)) deallocate (zc%restore_bowner)   ! (loaded twice)
        do j = 1, 4
            call buf_get(buf, k(j))
        end do
        if (any(k < 0) .or. any(k(1:3) > huge(1))) buf%bad = .true.
        if (.not. allocated(zc%glast)) buf%bad = .true.
        if (buf%bad) return
        zc%step = int(k(1))
        zc%restore_computed = int(k(2))
        zc%restore_evicted = int(k(3))
        zc%restore_peak = k(4)
        zc%restore_glast = zc%glast
        call buf_get(buf, zc%restore_glast)
        if (any(zc%restore_glast < -1 .or. zc%restore_glast > zc%step)) buf%bad = .true.
        call buf_get(buf, cap)
        if (cap >= 0 .neqv. allocated(zc%bslot)) buf%bad = .true.
        if (buf%bad) return
        if (cap >= 0) then
            if (cap > size(zc%bslot)) then
                buf%bad = .true.
                return
            end if
            allocate (zc%restore_bowner(cap))
            call buf_get(buf, zc%restore_bowner)
            call buf_get(buf, zc%blast)
            if (any(zc%restore_bowner < 0 .or. zc%restore_bowner > size(zc%bslot))) &
                buf%bad = .true.
        end if
        zc%restore_due = .not. buf%bad
    end subroutine zcache_load

    !> After zcache_load, before the first step: solve the groups the checkpoint's cache
    !> held (each whole, as when first solved: the same bits), and make room for its
    !> basis columns in the same slots. The caller then forms each of them
    !> (zcache_basis_reform in every slot s with bowner(s) > 0: it knows the vectors) and
    !> calls zcache_restore_finish. The solves are not counted (the counters are the
    !> checkpoint's; the caller's solver counts are its to put back). A restart's set-up
    !> work, as zcache_ensure_all is a new run's: the stop flag is read before each group
    !> (module stop_signal), STAT_INTERRUPTED when it is set.
    subroutine zcache_restore(zc, lu, a, val, cdofs, stat, errmsg)
        type(zcache_t), intent(inout) :: zc          !! cache (zcache_load done)
        type(factor_t), intent(inout) :: lu          !! factors of J0
        type(csc_t), intent(in) :: a                 !! the pattern of J0 (the model's)
        real(dp), intent(in) :: val(:)               !! (a%nnz) J0's values on it
        integer, intent(in) :: cdofs(:)              !! (m) the contact-cell dofs
        integer, intent(out) :: stat                 !! status (of the solves)
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: g, s, cap
        stat = STAT_OK
        do g = 1, size(zc%restore_glast)
            if (zc%restore_glast(g) < 0) cycle
            call check_stop('the contact columns', stat, errmsg)
            if (stat /= STAT_OK) return
            call solve_group(zc, lu, a, val, cdofs, g, stat, errmsg)
            if (stat /= STAT_OK) return
        end do
        if (allocated(zc%restore_bowner)) then
            cap = size(zc%restore_bowner)
            deallocate (zc%zb, zc%brange, zc%bowner)
            allocate (zc%zb(zc%n, cap), zc%brange(2, cap))
            call move_alloc(zc%restore_bowner, zc%bowner)
            zc%bslot = 0
            do s = 1, cap
                if (zc%bowner(s) == 0) cycle
                zc%bslot(zc%bowner(s)) = s
                zc%bytes = zc%bytes + 8_i8 * zc%n
            end do
        end if
    end subroutine zcache_restore

    !> Form the basis column of slot s again (zcache_restore): the groups of the columns
    !> of Z it reads are solved first where not held (the checkpoint's cache may have
    !> dropped them since; zcache_restore_finish drops them again), the stop flag read
    !> before each (STAT_INTERRUPTED), as in zcache_restore.
    subroutine zcache_basis_reform(zc, lu, a, val, cdofs, s, cols, coef, stat, errmsg)
        type(zcache_t), intent(inout) :: zc          !! cache (zcache_restore done)
        type(factor_t), intent(inout) :: lu          !! factors of J0
        type(csc_t), intent(in) :: a                 !! the pattern of J0 (the model's)
        real(dp), intent(in) :: val(:)               !! (a%nnz) J0's values on it
        integer, intent(in) :: cdofs(:)              !! (m) the contact-cell dofs
        integer, intent(in) :: s                     !! basis slot (bowner(s) > 0)
        integer, intent(in) :: cols(:)               !! its vector's contact-cell dofs (<= 0: none)
        real(dp), intent(in) :: coef(:)              !! and its entries there
        integer, intent(out) :: stat                 !! status (of the solves)
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: e
        stat = STAT_OK
        do e = 1, size(cols)
            if (cols(e) <= 0) cycle
            if (zc%slot(cols(e)) > 0) cycle
            call check_stop('the contact columns', stat, errmsg)
            if (stat /= STAT_OK) return
            call solve_group(zc, lu, a, val, cdofs, (cols(e) - 1) / ZCHUNK + 1, stat, errmsg)
            if (stat /= STAT_OK) return
        end do
        call zcache_basis_form(zc, s, cols, coef)
    end subroutine zcache_basis_reform

    !> The end of a restore: the groups solved only to form basis columns are dropped,
    !> and the groups' steps and the counters are the checkpoint's.
    pure subroutine zcache_restore_finish(zc)
        type(zcache_t), intent(inout) :: zc          !! cache (zcache_restore done)
        integer :: g
        do g = 1, size(zc%glast)
            if (zc%glast(g) >= 0 .and. zc%restore_glast(g) < 0) call drop_group(zc, g)
        end do
        zc%glast = zc%restore_glast
        zc%computed = zc%restore_computed
        zc%evicted = zc%restore_evicted
        zc%peak_bytes = zc%restore_peak
        zc%restore_due = .false.
        deallocate (zc%restore_glast)
    end subroutine zcache_restore_finish

    !> Drop the basis column least recently used before the current step (dropped:
    !> .false. when there is none).
    pure subroutine drop_basis(zc, dropped)
        type(zcache_t), intent(inout) :: zc          !! cache
        logical, intent(out) :: dropped              !! one was dropped
        integer :: s, k, old
        dropped = .false.
        if (.not. allocated(zc%bowner)) return
        old = 0
        do s = 1, size(zc%bowner)
            k = zc%bowner(s)
            if (k == 0) cycle
            if (zc%blast(k) >= zc%step) cycle
            if (old == 0) then
                old = s
            else if (zc%blast(k) < zc%blast(zc%bowner(old))) then
                old = s
            end if
        end do
        if (old == 0) return
        zc%bslot(zc%bowner(old)) = 0
        zc%bowner(old) = 0
        zc%bytes = zc%bytes - 8_i8 * zc%n
        dropped = .true.
    end subroutine drop_basis

    !> y <- y + sum_k t(k) Z b_k over the k with t(k) /= 0, in the order of k (each
    !> entry's additions in that order), each on its range of rows. Every such b_k must
    !> be held. Four columns a pass over y (add_group), so y is read and written once
    !> for four columns instead of once a column.
    pure subroutine zcache_add_basis(zc, t, y)
        type(zcache_t), intent(in) :: zc             !! cache
        real(dp), intent(in) :: t(:)                 !! (basis vectors) coefficients
        real(dp), intent(inout) :: y(:)              !! (n) updated
        integer :: k, s, nc, ss(4), lo(4), hi(4)
        real(dp) :: tt(4)
        nc = 0
        do k = 1, size(t)
            if (t(k) == 0.0_dp) cycle
            s = zc%bslot(k)
            if (zc%brange(2, s) < zc%brange(1, s)) cycle
            nc = nc + 1
            ss(nc) = s
            tt(nc) = t(k)
            lo(nc) = zc%brange(1, s)
            hi(nc) = zc%brange(2, s)
            if (nc == 4) then
                call add_group(zc, nc, ss, tt, lo, hi, y)
                nc = 0
            end if
        end do
        if (nc > 0) call add_group(zc, nc, ss, tt, lo, hi, y)
    end subroutine zcache_add_basis

    !> y <- y + sum_i tt(i) Z b (column ss(i) of zb) on its rows lo(i)..hi(i), i = 1..nc
    !> (nc <= 4) in that order: the rows are cut where a range starts or ends, and each
    !> piece gets the columns whose ranges cover it in one pass (add1 to add4), so
    !> every entry receives the same additions in the same order as column after column.
    pure subroutine add_group(zc, nc, ss, tt, lo, hi, y)
        type(zcache_t), intent(in) :: zc             !! cache
        integer, intent(in) :: nc                    !! columns (1 to 4)
        integer, intent(in) :: ss(4), lo(4), hi(4)   !! their slots and ranges (lo <= hi)
        real(dp), intent(in) :: tt(4)                !! their coefficients
        real(dp), intent(inout) :: y(:)              !! (n) updated
        integer :: cut(8), nb, i, j, a, b, na, sa(4)
        real(dp) :: ta(4)
        ! the cuts: every range's first row and the row after its last, ascending
        nb = 0
        do i = 1, nc
            call insert_cut(cut, nb, lo(i))
            call insert_cut(cut, nb, hi(i) + 1)
        end do
        do j = 1, nb - 1
            a = cut(j)
            b = cut(j + 1) - 1
            na = 0
            do i = 1, nc
                if (lo(i) <= a .and. hi(i) >= b) then
                    na = na + 1
                    sa(na) = ss(i)
                    ta(na) = tt(i)
                end if
            end do
            select case (na)
            case (4)
                call add4(b - a + 1, zc%zb(a:b, sa(1)), zc%zb(a:b, sa(2)), zc%zb(a:b, sa(3)), &
                          zc%zb(a:b, sa(4)), ta(1), ta(2), ta(3), ta(4), y(a:b))
            case (3)
                call add3(b - a + 1, zc%zb(a:b, sa(1)), zc%zb(a:b, sa(2)), zc%zb(a:b, sa(3)), &
                          ta(1), ta(2), ta(3), y(a:b))
            case (2)
                call add2(b - a + 1, zc%zb(a:b, sa(1)), zc%zb(a:b, sa(2)), ta(1), ta(2), y(a:b))
            case (1)
                call add1(b - a + 1, zc%zb(a:b, sa(1)), ta(1), y(a:b))
            end select
        end do
    end subroutine add_group

    !> c put into the ascending list cut(1:nb) unless it is there.
    pure subroutine insert_cut(cut, nb, c)
        integer, intent(inout) :: cut(:)             !! the list
        integer, intent(inout) :: nb                 !! its length
        integer, intent(in) :: c                     !! the value
        integer :: p
        do p = 1, nb
            if (cut(p) == c) return
        end do
        nb = nb + 1
        p = nb
        do while (p > 1)
            if (cut(p - 1) < c) exit
            cut(p) = cut(p - 1)
            p = p - 1
        end do
        cut(p) = c
    end subroutine insert_cut

    !> A new step: the columns needed from now on are the current step's.
    pure subroutine zcache_new_step(zc)
        type(zcache_t), intent(inout) :: zc          !! cache
        zc%step = zc%step + 1
    end subroutine zcache_new_step

    !> Make the columns need(:) (entries <= 0 ignored, repeats allowed) available, solving
    !> the groups not held, and mark their groups used at the current step; then drop the
    !> least recently used groups of earlier steps while the cache exceeds its budget.
    subroutine zcache_ensure(zc, lu, a, val, cdofs, need, stat, errmsg)
        type(zcache_t), intent(inout) :: zc          !! cache
        type(factor_t), intent(inout) :: lu          !! factors of J0
        type(csc_t), intent(in) :: a                 !! the pattern of J0 (the model's)
        real(dp), intent(in) :: val(:)               !! (a%nnz) J0's values on it
        integer, intent(in) :: cdofs(:)              !! (m) the contact-cell dofs
        integer, intent(in) :: need(:)               !! columns needed
        integer, intent(out) :: stat                 !! status (of the solves)
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: k, l, g, np, q
        stat = STAT_OK
        np = 0
        do k = 1, size(need)
            l = need(k)
            if (l <= 0) cycle
            g = (l - 1) / ZCHUNK + 1
            if (zc%glast(g) >= 0) then
                zc%glast(g) = zc%step
            else if (zc%slot(l) == 0) then
                np = np + 1
                zc%pending(np) = g
                zc%slot(group_first(g):group_last(zc, g)) = -1
            end if
        end do
        do q = 1, np
            call solve_group(zc, lu, a, val, cdofs, zc%pending(q), stat, errmsg)
            if (stat /= STAT_OK) then
                where (zc%slot < 0) zc%slot = 0
                return
            end if
        end do
        if (np > 0) call evict(zc)
    end subroutine zcache_ensure

    !> Every column, group after group, without a budget: the full precomputation (the
    !> augmented Lagrangian's Newton uses all of W). On an empty cache slot l then holds
    !> column l, so w(:, 1:m) is W. A set-up's work: the stop flag is read before each
    !> group (module stop_signal), STAT_INTERRUPTED when it is set.
    subroutine zcache_ensure_all(zc, lu, a, val, cdofs, stat, errmsg)
        type(zcache_t), intent(inout) :: zc          !! cache (empty)
        type(factor_t), intent(inout) :: lu          !! factors of J0
        type(csc_t), intent(in) :: a                 !! the pattern of J0 (the model's)
        real(dp), intent(in) :: val(:)               !! (a%nnz) J0's values on it
        integer, intent(in) :: cdofs(:)              !! (m) the contact-cell dofs
        integer, intent(out) :: stat                 !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: l, g
        stat = STAT_OK
        if (zc%m == 0) return
        zc%budget = huge(zc%budget)
        do g = 1, (zc%m - 1) / ZCHUNK + 1
            call check_stop('the contact columns', stat, errmsg)
            if (stat /= STAT_OK) return
            call zcache_ensure(zc, lu, a, val, cdofs, &
                               [(l, l = group_first(g), group_last(zc, g))], stat, errmsg)
            if (stat /= STAT_OK) return
        end do
    end subroutine zcache_ensure_all

    !> Solve the columns of group g (not held) in one call and store them.
    subroutine solve_group(zc, lu, a, val, cdofs, g, stat, errmsg)
        type(zcache_t), intent(inout) :: zc          !! cache
        type(factor_t), intent(inout) :: lu          !! factors of J0
        type(csc_t), intent(in) :: a                 !! the pattern of J0 (the model's)
        real(dp), intent(in) :: val(:)               !! (a%nnz) J0's values on it
        integer, intent(in) :: cdofs(:)              !! (m) the contact-cell dofs
        integer, intent(in) :: g                     !! group
        integer, intent(out) :: stat                 !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), allocatable :: e(:, :), zb(:, :)
        integer :: j0, nb, j, l, s, i, nk
        real(dp) :: cmax
        stat = STAT_OK
        j0 = group_first(g) - 1
        nb = group_last(zc, g) - j0
        allocate (e(zc%n, nb), zb(zc%n, nb), stat=i)
        if (i /= 0) then
            call columns_oom(zc, 16.0_dp * zc%n * nb, stat, errmsg)
            return
        end if
        e = 0.0_dp
        do j = 1, nb
            e(cdofs(j0 + j), j) = 1.0_dp
        end do
        call ls_solve_many(lu, a, e, zb, stat, errmsg, val)
        if (stat == STAT_INTERNAL .and. present(errmsg)) then
            ! the solves' work: named as the columns' (the stage the user sees)
            if (is_oom_text(errmsg)) call columns_oom(zc, 8.0_dp * zc%n * nb, &
                                                                      stat, errmsg)
        end if
        if (stat /= STAT_OK) return
        deallocate (e)
        do j = 1, nb
            l = j0 + j
            s = free_slot(zc)
            zc%owner(s) = l
            zc%slot(l) = s
            zc%w(:, s) = zb(cdofs, j)
            cmax = -1.0_dp
            if (zc%drop) cmax = ZDROP * maxval(abs(zb(:, j)))
            if (zc%drop) then
                nk = count(abs(zb(:, j)) > cmax)
                allocate (zc%z(s)%rows(nk), zc%z(s)%val(nk), stat=i)
                if (i /= 0) then
                    zc%owner(s) = 0
                    zc%slot(l) = 0
                    call columns_oom(zc, 12.0_dp * nk, stat, errmsg)
                    return
                end if
                nk = 0
                do i = 1, zc%n
                    if (abs(zb(i, j)) > cmax) then
                        nk = nk + 1
                        zc%z(s)%rows(nk) = i
                        zc%z(s)%val(nk) = zb(i, j)
                    end if
                end do
            else
                zc%z(s)%val = zb(:, j)
            end if
            zc%bytes = zc%bytes + column_bytes(zc, zc%z(s))
            zc%held = zc%held + 1
            zc%computed = zc%computed + 1
        end do
        zc%glast(g) = zc%step
        zc%peak_bytes = max(zc%peak_bytes, zc%bytes)
    end subroutine solve_group

    !> The line of an allocation of the cache that failed (STAT_INTERNAL): the bytes it
    !> asked for and those the cache held.
    pure subroutine columns_oom(zc, bytes, stat, errmsg)
        type(zcache_t), intent(in) :: zc             !! cache
        real(dp), intent(in) :: bytes                !! the allocation that failed
        integer, intent(out) :: stat                 !! STAT_INTERNAL
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=:), allocatable :: held
        held = ''
        if (zc%bytes > 0) held = ', with '//mb_text(real(zc%bytes, dp))//' held'
        call raise(stat, errmsg, STAT_INTERNAL, oom_text('the contact columns (the '// &
                   'columns of J0^-1 the contact correction keeps)', mb_text(bytes)// &
                   ' more'//held, OOM_HINT_MESH))
    end subroutine columns_oom

    !> The first column of group g.
    pure integer function group_first(g)
        integer, intent(in) :: g                     !! group
        group_first = ZCHUNK * (g - 1) + 1
    end function group_first

    !> The last column of group g.
    pure integer function group_last(zc, g)
        type(zcache_t), intent(in) :: zc             !! cache
        integer, intent(in) :: g                     !! group
        group_last = min(zc%m, ZCHUNK * g)
    end function group_last

    !> Bytes of one held column (W's and Z's parts).
    pure integer(i8) function column_bytes(zc, zcol)
        type(zcache_t), intent(in) :: zc             !! cache
        type(zcol_t), intent(in) :: zcol             !! its Z part
        column_bytes = 8_i8 * zc%m + 8_i8 * size(zcol%val)
        if (allocated(zcol%rows)) column_bytes = column_bytes + 4_i8 * size(zcol%rows)
    end function column_bytes

    !> A free slot (the slot arrays doubled when full).
    integer function free_slot(zc) result(s)
        type(zcache_t), intent(inout) :: zc          !! cache
        integer, allocatable :: itmp(:)
        real(dp), allocatable :: wtmp(:, :)
        type(zcol_t), allocatable :: ztmp(:)
        integer :: cap, ncap, k
        cap = size(zc%owner)
        do s = 1, cap
            if (zc%owner(s) == 0) return
        end do
        ncap = min(zc%m, max(2 * cap, ZCHUNK))
        allocate (itmp(ncap))
        itmp = 0
        itmp(1:cap) = zc%owner
        call move_alloc(itmp, zc%owner)
        allocate (wtmp(zc%m, ncap))
        wtmp(:, 1:cap) = zc%w
        call move_alloc(wtmp, zc%w)
        allocate (ztmp(ncap))
        do k = 1, cap
            call move_alloc(zc%z(k)%rows, ztmp(k)%rows)
            call move_alloc(zc%z(k)%val, ztmp(k)%val)
        end do
        call move_alloc(ztmp, zc%z)
        s = cap + 1
    end function free_slot

    !> Drop the least recently used groups of earlier steps while bytes > budget, then
    !> the least recently used basis columns of earlier steps.
    pure subroutine evict(zc)
        type(zcache_t), intent(inout) :: zc          !! cache
        integer :: g, old
        logical :: dropped
        do while (zc%bytes > zc%budget)
            old = 0
            do g = 1, size(zc%glast)
                if (zc%glast(g) < 0 .or. zc%glast(g) >= zc%step) cycle
                if (old == 0) then
                    old = g
                else if (zc%glast(g) < zc%glast(old)) then
                    old = g
                end if
            end do
            if (old == 0) then
                call drop_basis(zc, dropped)
                if (.not. dropped) return
                cycle
            end if
            call drop_group(zc, old)
        end do
    end subroutine evict

    !> Drop the columns of group g (held).
    pure subroutine drop_group(zc, g)
        type(zcache_t), intent(inout) :: zc          !! cache
        integer, intent(in) :: g                     !! group
        integer :: l, s
        do l = group_first(g), group_last(zc, g)
            s = zc%slot(l)
            zc%bytes = zc%bytes - column_bytes(zc, zc%z(s))
            zc%slot(l) = 0
            zc%owner(s) = 0
            if (allocated(zc%z(s)%rows)) deallocate (zc%z(s)%rows)
            deallocate (zc%z(s)%val)
            zc%held = zc%held - 1
            zc%evicted = zc%evicted + 1
        end do
        zc%glast(g) = -1
    end subroutine drop_group

    !> y = W t over the columns with t(l) /= 0, in the order of l (the same sums as the
    !> dense product: a zero coefficient adds nothing). Every such column must be held.
    pure subroutine zcache_w_times(zc, t, y)
        type(zcache_t), intent(in) :: zc             !! cache
        real(dp), intent(in) :: t(:)                 !! (m) coefficients
        real(dp), intent(out) :: y(:)                !! (m) W t
        y = 0.0_dp
        call zcache_add_w(zc, t, y)
    end subroutine zcache_w_times

    !> y <- y + sum_l t(l) W(:, l) over the l with t(l) /= 0, column after column in the
    !> order of l (each entry's additions in that order). Every such column must be held.
    pure subroutine zcache_add_w(zc, t, y)
        type(zcache_t), intent(in) :: zc             !! cache
        real(dp), intent(in) :: t(:)                 !! (m) coefficients
        real(dp), intent(inout) :: y(:)              !! (m) updated
        integer :: l, q, nc, ls(4)
        nc = 0
        do l = 1, zc%m
            if (t(l) == 0.0_dp) cycle
            nc = nc + 1
            ls(nc) = zc%slot(l)
            if (nc == 4) then
                call add4(zc%m, zc%w(:, ls(1)), zc%w(:, ls(2)), zc%w(:, ls(3)), &
                          zc%w(:, ls(4)), t(zc%owner(ls(1))), t(zc%owner(ls(2))), &
                          t(zc%owner(ls(3))), t(zc%owner(ls(4))), y)
                nc = 0
            end if
        end do
        do q = 1, nc
            call add1(zc%m, zc%w(:, ls(q)), t(zc%owner(ls(q))), y)
        end do
    end subroutine zcache_add_w

    !> y(rows) <- y(rows) + sum_l t(l) Z(rows, l) over the l with t(l) /= 0, column after
    !> column in the order of l (each entry's additions in that order). Every such column
    !> must be held.
    pure subroutine zcache_add_z(zc, t, y)
        type(zcache_t), intent(in) :: zc             !! cache
        real(dp), intent(in) :: t(:)                 !! (m) coefficients
        real(dp), intent(inout) :: y(:)              !! (n) updated
        integer :: l, s
        do l = 1, zc%m
            if (t(l) == 0.0_dp) cycle
            s = zc%slot(l)
            if (allocated(zc%z(s)%rows)) then
                call scatter_add(size(zc%z(s)%rows), zc%z(s)%rows, zc%z(s)%val, t(l), y)
            else
                call add1(zc%n, zc%z(s)%val, t(l), y)
            end if
        end do
    end subroutine zcache_add_z

    !> y(rows) <- y(rows) + t v.
    pure subroutine scatter_add(k, rows, v, t, y)
        integer, intent(in) :: k                     !! entries
        integer, intent(in) :: rows(k)               !! rows
        real(dp), intent(in) :: v(k)                 !! values
        real(dp), intent(in) :: t                    !! coefficient
        real(dp), intent(inout) :: y(:)              !! updated
        integer :: i
        do i = 1, k
            y(rows(i)) = y(rows(i)) + t * v(i)
        end do
    end subroutine scatter_add

    !> y <- (((y + t1 a1) + t2 a2) + t3 a3) + t4 a4, one pass.
    pure subroutine add4(k, a1, a2, a3, a4, t1, t2, t3, t4, y)
        integer, intent(in) :: k                     !! rows
        real(dp), intent(in) :: a1(k), a2(k), a3(k), a4(k)  !! columns
        real(dp), intent(in) :: t1, t2, t3, t4       !! coefficients
        real(dp), intent(inout) :: y(k)              !! updated
        integer :: i
        do i = 1, k
            y(i) = (((y(i) + t1 * a1(i)) + t2 * a2(i)) + t3 * a3(i)) + t4 * a4(i)
        end do
    end subroutine add4

    !> y <- ((y + t1 a1) + t2 a2) + t3 a3, one pass.
    pure subroutine add3(k, a1, a2, a3, t1, t2, t3, y)
        integer, intent(in) :: k                     !! rows
        real(dp), intent(in) :: a1(k), a2(k), a3(k)  !! columns
        real(dp), intent(in) :: t1, t2, t3           !! coefficients
        real(dp), intent(inout) :: y(k)              !! updated
        integer :: i
        do i = 1, k
            y(i) = ((y(i) + t1 * a1(i)) + t2 * a2(i)) + t3 * a3(i)
        end do
    end subroutine add3

    !> y <- (y + t1 a1) + t2 a2, one pass.
    pure subroutine add2(k, a1, a2, t1, t2, y)
        integer, intent(in) :: k                     !! rows
        real(dp), intent(in) :: a1(k), a2(k)         !! columns
        real(dp), intent(in) :: t1, t2               !! coefficients
        real(dp), intent(inout) :: y(k)              !! updated
        integer :: i
        do i = 1, k
            y(i) = (y(i) + t1 * a1(i)) + t2 * a2(i)
        end do
    end subroutine add2

    !> y <- y + t a.
    pure subroutine add1(k, a, t, y)
        integer, intent(in) :: k                     !! rows
        real(dp), intent(in) :: a(k)                 !! column
        real(dp), intent(in) :: t                    !! coefficient
        real(dp), intent(inout) :: y(k)              !! updated
        integer :: i
        do i = 1, k
            y(i) = y(i) + t * a(i)
        end do
    end subroutine add1
end module contact_columns
