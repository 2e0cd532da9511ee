!> CHOLMOD (SuiteSparse) binding: simplicial LDL^T factorization of symmetric csc_t
!> matrices, through the flat C shim cholmod_shim.c (which owns cholmod_common and
!> cholmod_factor; Fortran only holds an opaque handle).
!>
!> P A P^T = L D L^T, L unit lower triangular, D diagonal, P CHOLMOD's fill-reducing
!> permutation. Only the upper triangle of A is read. A zero, negative or non-finite
!> pivot gives STAT_NUMERIC ('not positive definite'): the caller decides what to do
!> (linear_solver falls back to UMFPACK's LU).
!>
!> The factors are copied out once per factorization and the solves are our own
!> loops (chol_solve): on the h = 0.01 iteration matrix they cost about half of
!> cholmod_solve2 with reused workspace (docs/numerics.md, "Linear solvers"), which
!> stays available as chol_solve_cholmod for comparison.
!> A cholmod_t owns a C handle: never copy one by assignment (double free).
module cholmod
    use iso_c_binding, only: c_ptr, c_null_ptr, c_int, c_long, c_double, c_associated
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, STAT_INTERNAL, raise
    use sparse, only: csc_t
    implicit none
    private

    ! Statuses of cholmod_shim.c.
    integer(c_int), parameter :: DC_OK = 0, DC_NOT_POSDEF = 1, DC_OUT_OF_MEMORY = 2

    !> LDL^T factors of one symmetric matrix (the symbolic analysis is kept across
    !> numeric refactorizations of the same pattern).
    type, public :: cholmod_t
        type(c_ptr) :: handle = c_null_ptr       !! cholmod_shim handle
        integer :: n = 0                         !! size factorized (0: no factors)
        integer :: lnz = 0                       !! entries of L below the diagonal
        integer :: factorizations = 0            !! numeric factorizations done (kept by chol_free)
        integer :: analyses = 0                  !! symbolic analyses done (kept by chol_free)
        integer, allocatable :: perm(:)          !! (n) 1-based: row perm(k) of A is pivot k
        real(dp), allocatable :: dinv(:)         !! (n) 1 / D
        integer, allocatable :: lc_ptr(:)        !! (n+1) strictly lower L by columns (1-based starts)
        integer, allocatable :: lc_row(:)        !! (lnz) 1-based rows
        real(dp), allocatable :: lc_val(:)       !! (lnz) values
        integer, allocatable :: lr_ptr(:)        !! (n+1) the same by rows (1-based starts)
        integer, allocatable :: lr_col(:)        !! (lnz) 1-based columns
        real(dp), allocatable :: lr_val(:)       !! (lnz) values
        real(dp), allocatable :: w(:)            !! (n) solve workspace
    end type cholmod_t

    public :: chol_factor, chol_solve, chol_solve_cholmod, chol_free

    interface
        !> void *dc_cholmod_new(void)
        function dc_cholmod_new() result(h) bind(C, name='dc_cholmod_new')
            import :: c_ptr
            type(c_ptr) :: h
        end function dc_cholmod_new

        !> void dc_cholmod_free(void *h)
        subroutine dc_cholmod_free(h) bind(C, name='dc_cholmod_free')
            import :: c_ptr
            type(c_ptr), value :: h                      !! handle
        end subroutine dc_cholmod_free

        !> int dc_cholmod_factor(h, n, colptr, rowind, val, &analysed, &lnz, &minor)
        function dc_cholmod_factor(h, n, colptr, rowind, val, analysed, lnz, minor) &
            result(status) bind(C, name='dc_cholmod_factor')
            import :: c_ptr, c_int, c_long, c_double
            type(c_ptr), value :: h                      !! handle
            integer(c_int), value :: n                   !! size
            integer(c_int), intent(in) :: colptr(*)      !! column starts (0-based)
            integer(c_int), intent(in) :: rowind(*)      !! row indices (0-based)
            real(c_double), intent(in) :: val(*)         !! values
            integer(c_int), intent(out) :: analysed      !! 1 if the analysis was redone
            integer(c_long), intent(out) :: lnz          !! entries of L below the diagonal
            integer(c_int), intent(out) :: minor         !! failing column (0-based) or -1
            integer(c_int) :: status
        end function dc_cholmod_factor

        !> int dc_cholmod_export(h, perm, lp, li, lx, d)
        function dc_cholmod_export(h, perm, lp, li, lx, d) result(status) &
            bind(C, name='dc_cholmod_export')
            import :: c_ptr, c_int, c_double
            type(c_ptr), value :: h                      !! handle
            integer(c_int), intent(out) :: perm(*)       !! (n) 0-based permutation
            integer(c_int), intent(out) :: lp(*)         !! (n+1) 0-based column starts
            integer(c_int), intent(out) :: li(*)         !! (lnz) 0-based rows
            real(c_double), intent(out) :: lx(*)         !! (lnz) values
            real(c_double), intent(out) :: d(*)          !! (n) D
            integer(c_int) :: status
        end function dc_cholmod_export

        !> int dc_cholmod_solve(h, ncol, b, x)
        function dc_cholmod_solve(h, ncol, b, x) result(status) bind(C, name='dc_cholmod_solve')
            import :: c_ptr, c_int, c_double
            type(c_ptr), value :: h                      !! handle
            integer(c_int), value :: ncol                !! right-hand sides
            real(c_double), intent(in) :: b(*)           !! (n, ncol)
            real(c_double), intent(out) :: x(*)          !! (n, ncol)
            integer(c_int) :: status
        end function dc_cholmod_solve
    end interface

contains

    !> Factorize the symmetric matrix a (its upper triangle is read): P A P^T = L D L^T,
    !> simplicial. The analysis is redone only when n or the pattern changed. A zero,
    !> negative or non-finite pivot gives STAT_NUMERIC (no factors kept); CHOLMOD
    !> errors give STAT_INTERNAL; an inconsistent csc_t gives STAT_BAD_INPUT.
    subroutine chol_factor(ch, a, stat, errmsg)
        type(cholmod_t), intent(inout) :: ch                !! factors (created or replaced)
        type(csc_t), intent(in) :: a                        !! symmetric matrix
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(c_int) :: status, analysed, minor
        integer(c_long) :: lnz
        integer(c_int), allocatable :: lp(:), li(:), perm(:)
        real(c_double), allocatable :: lx(:), d(:)
        integer :: n, i, j, k, ierr
        integer, allocatable :: fill(:)
        character(len=160) :: buf

        ch%n = 0
        if (a%n < 1 .or. .not. (allocated(a%colptr) .and. allocated(a%rowind) .and. &
                                allocated(a%val))) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'chol_factor: matrix is empty or not allocated')
            return
        end if
        if (size(a%colptr) < a%n + 1 .or. a%colptr(1) /= 0 .or. a%colptr(a%n + 1) /= a%nnz &
            .or. size(a%rowind) < a%nnz .or. size(a%val) < a%nnz) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'chol_factor: inconsistent CSC arrays')
            return
        end if
        if (.not. c_associated(ch%handle)) ch%handle = dc_cholmod_new()
        if (.not. c_associated(ch%handle)) then
            call raise(stat, errmsg, STAT_INTERNAL, 'chol_factor: out of memory')
            return
        end if
        status = dc_cholmod_factor(ch%handle, int(a%n, c_int), a%colptr, a%rowind, a%val, &
                                   analysed, lnz, minor)
        if (analysed /= 0) ch%analyses = ch%analyses + 1
        ch%factorizations = ch%factorizations + 1
        select case (status)
        case (DC_OK)
        case (DC_NOT_POSDEF)
            write (buf, '(a, i0, a)') 'chol_factor: not positive definite (pivot ', minor + 1, &
                ' is zero, negative or not finite)'
            call raise(stat, errmsg, STAT_NUMERIC, trim(buf))
            return
        case (DC_OUT_OF_MEMORY)
            call raise(stat, errmsg, STAT_INTERNAL, 'chol_factor: out of memory')
            return
        case default
            call raise(stat, errmsg, STAT_INTERNAL, 'chol_factor: CHOLMOD failed')
            return
        end select

        n = a%n
        allocate (lp(n + 1), li(max(1_c_long, lnz)), lx(max(1_c_long, lnz)), perm(n), d(n), &
                  fill(n + 1), stat=ierr)
        if (ierr /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, 'chol_factor: out of memory')
            return
        end if
        status = dc_cholmod_export(ch%handle, perm, lp, li, lx, d)
        if (status /= DC_OK) then
            call raise(stat, errmsg, STAT_INTERNAL, 'chol_factor: CHOLMOD factor export failed')
            return
        end if
        if (allocated(ch%perm)) deallocate (ch%perm, ch%dinv, ch%lc_ptr, ch%lc_row, ch%lc_val, &
                                            ch%lr_ptr, ch%lr_col, ch%lr_val, ch%w)
        ch%lnz = int(lnz)
        allocate (ch%perm(n), ch%dinv(n), ch%lc_ptr(n + 1), ch%lc_row(ch%lnz), &
                  ch%lc_val(ch%lnz), ch%lr_ptr(n + 1), ch%lr_col(ch%lnz), ch%lr_val(ch%lnz), &
                  ch%w(n), stat=ierr)
        if (ierr /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, 'chol_factor: out of memory')
            return
        end if
        ch%perm = perm + 1
        ch%dinv = 1.0_dp / d
        ch%lc_ptr = lp + 1
        ch%lc_row = li(1:ch%lnz) + 1
        ch%lc_val = lx(1:ch%lnz)
        ! the same strictly lower L by rows (the forward solve gathers too)
        fill = 0
        do k = 1, ch%lnz
            fill(ch%lc_row(k) + 1) = fill(ch%lc_row(k) + 1) + 1
        end do
        fill(1) = 1
        do i = 2, n + 1
            fill(i) = fill(i) + fill(i - 1)
        end do
        ch%lr_ptr = fill
        do j = 1, n
            do k = ch%lc_ptr(j), ch%lc_ptr(j + 1) - 1
                i = ch%lc_row(k)
                ch%lr_col(fill(i)) = j
                ch%lr_val(fill(i)) = ch%lc_val(k)
                fill(i) = fill(i) + 1
            end do
        end do
        ch%n = n
        stat = STAT_OK
    end subroutine chol_factor

    !> Solve A x = b with the copied factors (no allocation): x = P^T L^-T D^-1 L^-1 P b.
    !> b and x must have n entries (STAT_BAD_INPUT otherwise, or without factors).
    subroutine chol_solve(ch, b, x, stat, errmsg)
        type(cholmod_t), intent(inout) :: ch                !! factors
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(out) :: x(:)                       !! solution (n)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: i, j, k
        real(dp) :: acc
        if (ch%n < 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'chol_solve: no factors')
            return
        end if
        if (size(b) /= ch%n .or. size(x) /= ch%n) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'chol_solve: b or x does not have n entries')
            return
        end if
        stat = STAT_OK
        associate (w => ch%w, n => ch%n)
            ! L y = P b, rows in order; then y = D^-1 y
            do i = 1, n
                acc = b(ch%perm(i))
                do k = ch%lr_ptr(i), ch%lr_ptr(i + 1) - 1
                    acc = acc - ch%lr_val(k) * w(ch%lr_col(k))
                end do
                w(i) = acc
            end do
            do i = 1, n
                w(i) = w(i) * ch%dinv(i)
            end do
            ! L^T z = y, columns of L (rows of L^T) in reverse order; x = P^T z
            do j = n, 1, -1
                acc = w(j)
                do k = ch%lc_ptr(j), ch%lc_ptr(j + 1) - 1
                    acc = acc - ch%lc_val(k) * w(ch%lc_row(k))
                end do
                w(j) = acc
                x(ch%perm(j)) = acc
            end do
        end associate
    end subroutine chol_solve

    !> Solve A X = B (columns of b) with cholmod_solve2 (workspaces reused; the
    !> comparison path of chol_solve).
    subroutine chol_solve_cholmod(ch, b, x, stat, errmsg)
        type(cholmod_t), intent(inout) :: ch                !! factors
        real(dp), intent(in), contiguous :: b(:, :)         !! right-hand sides (n, m)
        real(dp), intent(out), contiguous :: x(:, :)        !! solutions (n, m)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        if (ch%n < 1 .or. size(b, 1) /= ch%n .or. size(x, 1) /= ch%n .or. &
            size(b, 2) /= size(x, 2)) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'chol_solve_cholmod: no factors or bad sizes')
            return
        end if
        stat = STAT_OK
        if (size(b, 2) == 0) return
        if (dc_cholmod_solve(ch%handle, int(size(b, 2), c_int), b, x) /= DC_OK) &
            call raise(stat, errmsg, STAT_INTERNAL, 'chol_solve_cholmod: cholmod_solve2 failed')
    end subroutine chol_solve_cholmod

    !> Release the CHOLMOD objects and the copied factors (safe to call twice or on a
    !> fresh cholmod_t). The counters are kept.
    subroutine chol_free(ch)
        type(cholmod_t), intent(inout) :: ch   !! factors to release
        if (c_associated(ch%handle)) call dc_cholmod_free(ch%handle)
        ch%handle = c_null_ptr
        ch%n = 0
        ch%lnz = 0
        if (allocated(ch%perm)) deallocate (ch%perm, ch%dinv, ch%lc_ptr, ch%lc_row, ch%lc_val, &
                                            ch%lr_ptr, ch%lr_col, ch%lr_val, ch%w)
    end subroutine chol_free
end module cholmod
