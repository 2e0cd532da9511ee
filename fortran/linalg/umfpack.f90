!> UMFPACK (SuiteSparse) binding through ISO_C_BINDING: LU factorization and
!> solves of csc_t matrices, handles kept in lu_t.
!>
!> Usage in a time loop: call lu_factor(lu, a, ...) whenever the values of a change
!> (the symbolic analysis is reused automatically while n and the pattern stay the
!> same), lu_solve(lu, a, b, x, ...) as often as needed (any number of right-hand
!> sides, one after the other; no allocation), and lu_free(lu) at the end.
!> An lu_t owns C pointers: never copy one by assignment (double free).
module umfpack
    use iso_c_binding, only: c_ptr, c_null_ptr, c_double, c_int, c_associated
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, STAT_INTERNAL, raise, oom_text, &
                      mb_text, OOM_HINT_MESH
    use sparse, only: csc_t
    implicit none
    private

    ! Sizes and indices from umfpack.h (SuiteSparse 5.12, UMFPACK 5.7.9). Indices are
    ! C (0-based): Fortran reads control(UMFPACK_IRSTEP + 1).
    integer, parameter, public :: UMFPACK_CONTROL = 20   !! length of Control
    integer, parameter, public :: UMFPACK_INFO = 90      !! length of Info
    integer, parameter, public :: UMFPACK_PRL = 0        !! Control: print level
    integer, parameter, public :: UMFPACK_STRATEGY = 5   !! Control: strategy
    integer, parameter, public :: UMFPACK_IRSTEP = 7     !! Control: max. iterative refinement steps
    integer, parameter, public :: UMFPACK_ORDERING = 10  !! Control: ordering
    integer, parameter, public :: UMFPACK_STATUS = 0     !! Info: status of the last call
    integer, parameter, public :: UMFPACK_SIZE_OF_UNIT = 3   !! Info: bytes of a Unit
    integer, parameter, public :: UMFPACK_PEAK_MEMORY_ESTIMATE = 21 !! Info: the symbolic
                                                                    !! analysis' estimate of
                                                                    !! the peak (Units)
    integer, parameter, public :: UMFPACK_NUMERIC_SIZE = 40  !! Info: Numeric object size (Units)
    integer, parameter, public :: UMFPACK_FLOPS = 42     !! Info: flops of the factorization
    integer, parameter, public :: UMFPACK_LNZ = 43       !! Info: nnz(L) incl. diagonal
    integer, parameter, public :: UMFPACK_UNZ = 44       !! Info: nnz(U) incl. diagonal
    integer, parameter, public :: UMFPACK_RCOND = 67     !! Info: reciprocal condition estimate

    ! Status codes from umfpack.h.
    integer, parameter, public :: UMFPACK_OK = 0                               !! success
    integer, parameter, public :: UMFPACK_WARNING_singular_matrix = 1         !! singular
    integer, parameter, public :: UMFPACK_ERROR_out_of_memory = -1            !! out of memory
    integer, parameter, public :: UMFPACK_ERROR_invalid_Numeric_object = -3   !! bad Numeric
    integer, parameter, public :: UMFPACK_ERROR_invalid_Symbolic_object = -4  !! bad Symbolic
    integer, parameter, public :: UMFPACK_ERROR_argument_missing = -5         !! NULL argument
    integer, parameter, public :: UMFPACK_ERROR_n_nonpositive = -6            !! n <= 0
    integer, parameter, public :: UMFPACK_ERROR_invalid_matrix = -8           !! bad Ap/Ai
    integer, parameter, public :: UMFPACK_ERROR_different_pattern = -11       !! pattern changed
    integer, parameter, public :: UMFPACK_ERROR_invalid_system = -13          !! bad sys
    integer, parameter, public :: UMFPACK_ERROR_invalid_permutation = -15     !! bad permutation
    integer, parameter, public :: UMFPACK_ERROR_file_IO = -17                 !! file I/O
    integer, parameter, public :: UMFPACK_ERROR_ordering_failed = -18         !! ordering failed
    integer, parameter, public :: UMFPACK_ERROR_internal_error = -911         !! UMFPACK bug

    !> LU factors of one matrix (symbolic analysis kept across numeric refactorizations
    !> of the same pattern).
    type, public :: lu_t
        type(c_ptr) :: symbolic = c_null_ptr        !! UMFPACK symbolic object
        type(c_ptr) :: numeric = c_null_ptr         !! UMFPACK numeric object
        integer :: n = 0                            !! size factorized
        integer :: factorizations = 0               !! numeric factorizations done (kept by lu_free)
        integer :: analyses = 0                     !! symbolic analyses done (kept by lu_free)
        real(c_double) :: control(UMFPACK_CONTROL) = 0.0_dp  !! UMFPACK control (defaults, IRSTEP 0)
        real(c_double) :: info(UMFPACK_INFO) = 0.0_dp        !! UMFPACK info of the last call
        real(dp), allocatable :: w(:)               !! (n) lu_solve workspace
        integer(c_int), allocatable :: colptr(:)    !! pattern of the analysed matrix (reuse test)
        integer(c_int), allocatable :: rowind(:)    !! pattern of the analysed matrix (reuse test)
        ! Factors copied out of the Numeric object (P R A Q = L U), solved by our own
        ! row-oriented triangular loops: 2.3x faster than umfpack_di_wsolve on the
        ! h = 0.01 iteration matrix (56 against 127 us, docs/performance.md).
        integer(c_int), allocatable :: perm_p(:)    !! (n) 0-based: row perm_p(k) of A is pivot row k
        integer(c_int), allocatable :: perm_q(:)    !! (n) 0-based: column perm_q(k) of A is pivot column k
        real(dp), allocatable :: rscale(:)          !! (n) 1/Rs (or Rs when UMFPACK says do_recip)
        integer, allocatable :: l_ptr(:)            !! (n+1) strictly lower L, rows (1-based starts)
        integer, allocatable :: l_col(:)            !! 1-based columns
        real(dp), allocatable :: l_val(:)           !! values
        integer, allocatable :: u_ptr(:)            !! (n+1) strictly upper U, rows (1-based starts)
        integer, allocatable :: u_col(:)            !! 1-based columns
        real(dp), allocatable :: u_val(:)           !! values
        real(dp), allocatable :: u_dinv(:)          !! (n) 1 / diag(U)
    end type lu_t

    public :: lu_factor, lu_solve, lu_solve_many, lu_free, lu_rcond, umfpack_status_text

    interface
        !> int dc_blas_room(double extra) (cholmod_shim.c): room for extra bytes and the
        !> BLAS's buffer when it is still to be made
        function dc_blas_room(extra) result(ok) bind(C, name='dc_blas_room')
            import :: c_int, c_double
            real(c_double), value :: extra               !! bytes besides the buffer
            integer(c_int) :: ok
        end function dc_blas_room

        !> void dc_blas_made(void) (cholmod_shim.c): the BLAS has made its buffer
        subroutine dc_blas_made() bind(C, name='dc_blas_made')
        end subroutine dc_blas_made

        !> int umfpack_di_get_lunz(int *lnz, int *unz, int *n_row, int *n_col, int *nz_udiag, void *Numeric)
        function umfpack_di_get_lunz(lnz, unz, n_row, n_col, nz_udiag, numeric) &
            bind(C, name='umfpack_di_get_lunz') result(status)
            import :: c_int, c_ptr
            integer(c_int), intent(out) :: lnz, unz, n_row, n_col, nz_udiag
                !! entries of L and U, sizes, nonzeros on U's diagonal
            type(c_ptr), value :: numeric  !! Numeric object
            integer(c_int) :: status
        end function umfpack_di_get_lunz

        !> int umfpack_di_get_numeric(Lp, Lj, Lx, Up, Ui, Ux, P, Q, Dx, do_recip, Rs, Numeric)
        function umfpack_di_get_numeric(lp, lj, lx, up, ui, ux, p, q, dx, do_recip, rs, numeric) &
            bind(C, name='umfpack_di_get_numeric') result(status)
            import :: c_int, c_double, c_ptr
            integer(c_int), intent(out) :: lp(*), lj(*), up(*), ui(*), p(*), q(*)
                !! L by rows, U by columns, P, Q
            real(c_double), intent(out) :: lx(*), ux(*), dx(*), rs(*)
                !! L, U, diag(U), scale factors
            integer(c_int), intent(out) :: do_recip  !! 1: rs holds reciprocals
            type(c_ptr), value :: numeric            !! Numeric object
            integer(c_int) :: status
        end function umfpack_di_get_numeric

        !> void umfpack_di_defaults(double Control[UMFPACK_CONTROL])
        subroutine umfpack_di_defaults(control) bind(C, name='umfpack_di_defaults')
            import :: c_double
            real(c_double), intent(out) :: control(*)   !! Control array
        end subroutine umfpack_di_defaults

        !> int umfpack_di_symbolic(n_row, n_col, Ap, Ai, Ax, &Symbolic, Control, Info)
        function umfpack_di_symbolic(n_row, n_col, ap, ai, ax, symbolic, control, info) &
            result(status) bind(C, name='umfpack_di_symbolic')
            import :: c_int, c_double, c_ptr
            integer(c_int), value :: n_row                !! rows
            integer(c_int), value :: n_col                !! columns
            integer(c_int), intent(in) :: ap(*)           !! column pointers (0-based)
            integer(c_int), intent(in) :: ai(*)           !! row indices (0-based)
            real(c_double), intent(in) :: ax(*)           !! values
            type(c_ptr), intent(out) :: symbolic          !! new Symbolic object
            real(c_double), intent(in) :: control(*)      !! Control
            real(c_double), intent(inout) :: info(*)      !! Info
            integer(c_int) :: status
        end function umfpack_di_symbolic

        !> int umfpack_di_numeric(Ap, Ai, Ax, Symbolic, &Numeric, Control, Info)
        function umfpack_di_numeric(ap, ai, ax, symbolic, numeric, control, info) &
            result(status) bind(C, name='umfpack_di_numeric')
            import :: c_int, c_double, c_ptr
            integer(c_int), intent(in) :: ap(*)           !! column pointers (0-based)
            integer(c_int), intent(in) :: ai(*)           !! row indices (0-based)
            real(c_double), intent(in) :: ax(*)           !! values
            type(c_ptr), value :: symbolic                !! Symbolic object
            type(c_ptr), intent(out) :: numeric           !! new Numeric object
            real(c_double), intent(in) :: control(*)      !! Control
            real(c_double), intent(inout) :: info(*)      !! Info
            integer(c_int) :: status
        end function umfpack_di_numeric

        !> void umfpack_di_free_symbolic(void **Symbolic)
        subroutine umfpack_di_free_symbolic(symbolic) bind(C, name='umfpack_di_free_symbolic')
            import :: c_ptr
            type(c_ptr), intent(inout) :: symbolic        !! freed, set to NULL
        end subroutine umfpack_di_free_symbolic

        !> void umfpack_di_free_numeric(void **Numeric)
        subroutine umfpack_di_free_numeric(numeric) bind(C, name='umfpack_di_free_numeric')
            import :: c_ptr
            type(c_ptr), intent(inout) :: numeric         !! freed, set to NULL
        end subroutine umfpack_di_free_numeric
    end interface

contains

    !> Factorize A (symbolic once per pattern, numeric every call). The symbolic
    !> analysis of the previous call is reused when n and the pattern (colptr, rowind,
    !> compared in O(nnz)) are unchanged; otherwise it is redone with UMFPACK's default
    !> control and no iterative refinement (Control[UMFPACK_IRSTEP] = 0). Counts in
    !> lu%factorizations (numeric) and lu%analyses (symbolic). A singular matrix
    !> (UMFPACK status +1) gives STAT_NUMERIC "singular matrix" (the numeric object is
    !> freed, the analysis kept); other nonzero statuses give STAT_INTERNAL with
    !> UMFPACK's status number and meaning; an inconsistent csc_t gives STAT_BAD_INPUT.
    !> With `val`, the matrix factorized has a's pattern and the values val (a%val is not
    !> read).
    subroutine lu_factor(lu, a, stat, errmsg, val)
        type(lu_t), intent(inout) :: lu                    !! factors (created or replaced)
        type(csc_t), intent(in) :: a                        !! matrix (its pattern)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern
        if (present(val)) then
            call factor_values(lu, a, val, stat, errmsg)
        else if (allocated(a%val)) then
            call factor_values(lu, a, a%val, stat, errmsg)
        else
            call factor_values(lu, a, [real(dp) ::], stat, errmsg)
        end if
    end subroutine lu_factor

    !> lu_factor of the matrix with a's pattern and the values v.
    subroutine factor_values(lu, a, v, stat, errmsg)
        type(lu_t), intent(inout) :: lu                    !! factors (created or replaced)
        type(csc_t), intent(in) :: a                        !! the pattern
        real(dp), intent(in) :: v(:)                        !! (a%nnz) the values
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(c_int) :: status
        integer :: ierr
        logical :: reuse
        real(dp) :: peak

        if (c_associated(lu%numeric)) call umfpack_di_free_numeric(lu%numeric)
        lu%numeric = c_null_ptr
        if (.not. csc_consistent(a, size(v))) then
            call raise(stat, errmsg, STAT_BAD_INPUT, &
                       'lu_factor: matrix is empty or its CSC arrays are inconsistent')
            return
        end if

        reuse = c_associated(lu%symbolic) .and. lu%n == a%n
        if (reuse) reuse = same_pattern(lu, a)
        if (.not. reuse) then
            if (c_associated(lu%symbolic)) call umfpack_di_free_symbolic(lu%symbolic)
            lu%symbolic = c_null_ptr
            lu%n = 0
            call umfpack_di_defaults(lu%control)
            lu%control(UMFPACK_IRSTEP + 1) = 0.0_dp
            status = umfpack_di_symbolic(int(a%n, c_int), int(a%n, c_int), a%colptr, &
                                         a%rowind, v, lu%symbolic, lu%control, lu%info)
            if (status /= UMFPACK_OK) then
                if (c_associated(lu%symbolic)) call umfpack_di_free_symbolic(lu%symbolic)
                lu%symbolic = c_null_ptr
                call raise(stat, errmsg, STAT_INTERNAL, &
                           'lu_factor (symbolic): '//umfpack_status_text(int(status)))
                return
            end if
            lu%analyses = lu%analyses + 1
            call store_pattern(lu, a, ierr)
            if (ierr == 0) call ensure_workspace(lu, a%n, ierr)
            if (ierr /= 0) then
                call umfpack_di_free_symbolic(lu%symbolic)
                lu%symbolic = c_null_ptr
                call raise(stat, errmsg, STAT_INTERNAL, 'lu_factor: out of memory')
                return
            end if
            lu%n = a%n
        end if

        ! the symbolic analysis' estimate of the numerical factorization's peak and, at the
        ! process's first BLAS call, OpenBLAS's buffer (whose failed allocation OpenBLAS
        ! retries for ever: cholmod_shim.c, BLAS_BUFFER), asked for first
        peak = lu%info(UMFPACK_PEAK_MEMORY_ESTIMATE + 1) * lu%info(UMFPACK_SIZE_OF_UNIT + 1)
        if (dc_blas_room(max(peak, 0.0_dp)) == 0) then
            call raise(stat, errmsg, STAT_INTERNAL, oom_text('the factorization (UMFPACK''s LU)', &
                       'about '//mb_text(peak)//' estimated by its symbolic analysis, with '// &
                       'the BLAS''s buffer', OOM_HINT_MESH))
            return
        end if
        status = umfpack_di_numeric(a%colptr, a%rowind, v, lu%symbolic, lu%numeric, &
                                    lu%control, lu%info)
        lu%factorizations = lu%factorizations + 1
        if (status == UMFPACK_OK) call dc_blas_made()
        if (status == UMFPACK_OK) then
            call extract_factors(lu, stat, errmsg)
        else if (status == UMFPACK_ERROR_out_of_memory) then
            if (c_associated(lu%numeric)) call umfpack_di_free_numeric(lu%numeric)
            lu%numeric = c_null_ptr
            call raise(stat, errmsg, STAT_INTERNAL, oom_text('the factorization (UMFPACK''s LU)', &
                       'about '//mb_text(peak)//' estimated by its symbolic analysis', &
                       OOM_HINT_MESH))
        else
            if (c_associated(lu%numeric)) call umfpack_di_free_numeric(lu%numeric)
            lu%numeric = c_null_ptr
            if (status == UMFPACK_WARNING_singular_matrix) then
                call raise(stat, errmsg, STAT_NUMERIC, 'lu_factor: singular matrix')
            else
                call raise(stat, errmsg, STAT_INTERNAL, &
                           'lu_factor (numeric): '//umfpack_status_text(int(status)))
            end if
        end if
    end subroutine factor_values

    !> Solve A x = b with the factors of A (no allocation, no iterative refinement).
    !> May be called any number of times per factorization. b and x must have n
    !> entries (STAT_BAD_INPUT otherwise, or if lu holds no factors of an n x n matrix).
    pure subroutine lu_solve(lu, a, b, x, stat, errmsg)
        type(lu_t), intent(inout) :: lu                     !! factors of a
        type(csc_t), intent(in) :: a                        !! the factorized matrix
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(out) :: x(:)                       !! solution (n)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: i, k
        real(dp) :: acc
        if (.not. c_associated(lu%numeric) .or. lu%n /= a%n) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'lu_solve: no factors of this matrix')
            return
        end if
        if (size(b) /= lu%n .or. size(x) /= lu%n) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'lu_solve: b or x does not have n entries')
            return
        end if
        stat = STAT_OK
        associate (w => lu%w, n => lu%n)
            ! w = P R b
            do k = 1, n
                w(k) = b(lu%perm_p(k) + 1) * lu%rscale(lu%perm_p(k) + 1)
            end do
            ! L y = w (unit diagonal), rows in order
            do i = 1, n
                acc = w(i)
                do k = lu%l_ptr(i), lu%l_ptr(i + 1) - 1
                    acc = acc - lu%l_val(k) * w(lu%l_col(k))
                end do
                w(i) = acc
            end do
            ! U z = y, rows in reverse order
            do i = n, 1, -1
                acc = w(i)
                do k = lu%u_ptr(i), lu%u_ptr(i + 1) - 1
                    acc = acc - lu%u_val(k) * w(lu%u_col(k))
                end do
                w(i) = acc * lu%u_dinv(i)
            end do
            ! x = Q z
            do k = 1, n
                x(lu%perm_q(k) + 1) = w(k)
            end do
        end associate
    end subroutine lu_solve

    !> Copy L, U, P, Q and the row scaling out of the Numeric object into the row
    !> forms lu_solve uses (strictly triangular parts, inverse diagonal of U).
    subroutine extract_factors(lu, stat, errmsg)
        type(lu_t), intent(inout) :: lu                     !! factors
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(c_int) :: lnz, unz, nr, nc, nzd, status, do_recip
        integer(c_int), allocatable :: lp(:), lj(:), up(:), ui(:)
        real(c_double), allocatable :: lx(:), ux(:), dx(:), rs(:)
        integer :: n, i, j, k, cnt, ierr
        integer, allocatable :: fill(:)
        stat = STAT_OK
        status = umfpack_di_get_lunz(lnz, unz, nr, nc, nzd, lu%numeric)
        if (status /= UMFPACK_OK) then
            call raise(stat, errmsg, STAT_INTERNAL, 'lu_factor (get_lunz): ' &
                       //umfpack_status_text(int(status)))
            return
        end if
        n = lu%n
        allocate (lp(n + 1), lj(lnz), lx(lnz), up(n + 1), ui(unz), ux(unz), dx(n), rs(n), &
                  fill(n + 1), stat=ierr)
        if (ierr == 0 .and. allocated(lu%perm_p)) then
            if (size(lu%perm_p) /= n) deallocate (lu%perm_p, lu%perm_q, lu%rscale, lu%u_dinv, &
                                                  lu%l_ptr, lu%u_ptr)
        end if
        if (ierr == 0 .and. .not. allocated(lu%perm_p)) &
            allocate (lu%perm_p(n), lu%perm_q(n), lu%rscale(n), lu%u_dinv(n), lu%l_ptr(n + 1), &
                      lu%u_ptr(n + 1), stat=ierr)
        if (ierr /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, 'lu_factor: out of memory')
            return
        end if
        status = umfpack_di_get_numeric(lp, lj, lx, up, ui, ux, lu%perm_p, lu%perm_q, dx, &
                                        do_recip, rs, lu%numeric)
        if (status /= UMFPACK_OK) then
            call raise(stat, errmsg, STAT_INTERNAL, 'lu_factor (get_numeric): ' &
                       //umfpack_status_text(int(status)))
            return
        end if
        if (do_recip /= 0) then
            lu%rscale = rs
        else
            lu%rscale = 1.0_dp / rs
        end if
        lu%u_dinv = 1.0_dp / dx
        ! L: row form already; drop the unit diagonal (last in each row)
        if (allocated(lu%l_col)) deallocate (lu%l_col, lu%l_val)
        allocate (lu%l_col(lnz - n), lu%l_val(lnz - n))
        cnt = 0
        do i = 1, n
            lu%l_ptr(i) = cnt + 1
            do k = lp(i) + 1, lp(i + 1)
                if (lj(k) + 1 == i) cycle
                cnt = cnt + 1
                lu%l_col(cnt) = lj(k) + 1
                lu%l_val(cnt) = lx(k)
            end do
        end do
        lu%l_ptr(n + 1) = cnt + 1
        ! U: column form -> row form of its strictly upper part
        fill = 0
        do j = 1, n
            do k = up(j) + 1, up(j + 1)
                i = ui(k) + 1
                if (i /= j) fill(i + 1) = fill(i + 1) + 1
            end do
        end do
        fill(1) = 1
        do i = 2, n + 1
            fill(i) = fill(i) + fill(i - 1)
        end do
        lu%u_ptr = fill
        if (allocated(lu%u_col)) deallocate (lu%u_col, lu%u_val)
        allocate (lu%u_col(fill(n + 1) - 1), lu%u_val(fill(n + 1) - 1))
        do j = 1, n
            do k = up(j) + 1, up(j + 1)
                i = ui(k) + 1
                if (i == j) cycle
                lu%u_col(fill(i)) = j
                lu%u_val(fill(i)) = ux(k)
                fill(i) = fill(i) + 1
            end do
        end do
    end subroutine extract_factors

    !> Solve A X = B for the columns of B, one after the other (no allocation).
    pure subroutine lu_solve_many(lu, a, b, x, stat, errmsg)
        type(lu_t), intent(inout) :: lu                     !! factors of a
        type(csc_t), intent(in) :: a                        !! the factorized matrix
        real(dp), intent(in) :: b(:, :)                     !! right-hand sides (n, m)
        real(dp), intent(out) :: x(:, :)                    !! solutions (n, m)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: k
        if (size(b, 2) /= size(x, 2)) then
            call raise(stat, errmsg, STAT_BAD_INPUT, &
                       'lu_solve_many: b and x have different numbers of columns')
            return
        end if
        stat = STAT_OK
        do k = 1, size(b, 2)
            call lu_solve(lu, a, b(:, k), x(:, k), stat, errmsg)
            if (stat /= STAT_OK) return
        end do
    end subroutine lu_solve_many

    !> Release the UMFPACK objects and the workspace (safe to call twice or on a fresh
    !> lu_t). The counters factorizations and analyses are kept.
    subroutine lu_free(lu)
        type(lu_t), intent(inout) :: lu   !! factors to release
        if (c_associated(lu%numeric)) call umfpack_di_free_numeric(lu%numeric)
        if (c_associated(lu%symbolic)) call umfpack_di_free_symbolic(lu%symbolic)
        lu%numeric = c_null_ptr
        lu%symbolic = c_null_ptr
        lu%n = 0
        if (allocated(lu%w)) deallocate (lu%w)
        if (allocated(lu%colptr)) deallocate (lu%colptr)
        if (allocated(lu%rowind)) deallocate (lu%rowind)
        if (allocated(lu%perm_p)) deallocate (lu%perm_p, lu%perm_q, lu%rscale, lu%u_dinv, &
                                              lu%l_ptr, lu%u_ptr)
        if (allocated(lu%l_col)) deallocate (lu%l_col, lu%l_val)
        if (allocated(lu%u_col)) deallocate (lu%u_col, lu%u_val)
    end subroutine lu_free

    !> UMFPACK's reciprocal condition estimate of the last factorization
    !> (min |U_ii| / max |U_ii|; 0 if singular, -1 if not available).
    pure function lu_rcond(lu) result(rcond)
        type(lu_t), intent(in) :: lu   !! factors
        real(dp) :: rcond
        rcond = lu%info(UMFPACK_RCOND + 1)
    end function lu_rcond

    !> 'UMFPACK status N (meaning)' for an UMFPACK status code.
    pure function umfpack_status_text(status) result(text)
        integer, intent(in) :: status   !! UMFPACK status code
        character(len=:), allocatable :: text
        character(len=16) :: num
        character(len=:), allocatable :: meaning
        select case (status)
        case (UMFPACK_OK); meaning = 'ok'
        case (UMFPACK_WARNING_singular_matrix); meaning = 'singular matrix'
        case (2); meaning = 'determinant underflow'
        case (3); meaning = 'determinant overflow'
        case (UMFPACK_ERROR_out_of_memory); meaning = 'out of memory'
        case (UMFPACK_ERROR_invalid_Numeric_object); meaning = 'invalid Numeric object'
        case (UMFPACK_ERROR_invalid_Symbolic_object); meaning = 'invalid Symbolic object'
        case (UMFPACK_ERROR_argument_missing); meaning = 'argument missing'
        case (UMFPACK_ERROR_n_nonpositive); meaning = 'n nonpositive'
        case (UMFPACK_ERROR_invalid_matrix); meaning = 'invalid matrix'
        case (UMFPACK_ERROR_different_pattern); meaning = 'different pattern'
        case (UMFPACK_ERROR_invalid_system); meaning = 'invalid system'
        case (UMFPACK_ERROR_invalid_permutation); meaning = 'invalid permutation'
        case (UMFPACK_ERROR_file_IO); meaning = 'file I/O error'
        case (UMFPACK_ERROR_ordering_failed); meaning = 'ordering failed'
        case (UMFPACK_ERROR_internal_error); meaning = 'internal error'
        case default; meaning = 'unknown status'
        end select
        write (num, '(i0)') status
        text = 'UMFPACK status '//trim(num)//' ('//meaning//')'
    end function umfpack_status_text

    !> The pattern arrays of a are allocated, sized and closed consistently (n >= 1), and
    !> the nval values read with them are enough.
    pure function csc_consistent(a, nval) result(ok)
        type(csc_t), intent(in) :: a   !! matrix (its pattern)
        integer, intent(in) :: nval    !! values read on it
        logical :: ok
        ok = .false.
        if (a%n < 1 .or. a%nnz < 0) return
        if (.not. (allocated(a%colptr) .and. allocated(a%rowind))) return
        if (size(a%colptr) < a%n + 1 .or. size(a%rowind) < a%nnz .or. nval < a%nnz) return
        if (a%colptr(1) /= 0 .or. a%colptr(a%n + 1) /= a%nnz) return
        ok = .true.
    end function csc_consistent

    !> The pattern of a equals the one analysed in lu.
    pure function same_pattern(lu, a) result(same)
        type(lu_t), intent(in) :: lu   !! factors holding a pattern copy
        type(csc_t), intent(in) :: a   !! matrix (consistent)
        logical :: same
        integer :: k
        same = .false.
        if (.not. (allocated(lu%colptr) .and. allocated(lu%rowind))) return
        if (size(lu%colptr) /= a%n + 1 .or. size(lu%rowind) /= a%nnz) return
        do k = 1, a%n + 1
            if (lu%colptr(k) /= a%colptr(k)) return
        end do
        do k = 1, a%nnz
            if (lu%rowind(k) /= a%rowind(k)) return
        end do
        same = .true.
    end function same_pattern

    !> Keep a copy of the pattern of a in lu (for the reuse test).
    pure subroutine store_pattern(lu, a, ierr)
        type(lu_t), intent(inout) :: lu   !! factors
        type(csc_t), intent(in) :: a      !! analysed matrix
        integer, intent(out) :: ierr      !! allocation status
        ierr = 0
        if (allocated(lu%colptr)) then
            if (size(lu%colptr) /= a%n + 1) deallocate (lu%colptr)
        end if
        if (allocated(lu%rowind)) then
            if (size(lu%rowind) /= a%nnz) deallocate (lu%rowind)
        end if
        if (.not. allocated(lu%colptr)) allocate (lu%colptr(a%n + 1), stat=ierr)
        if (ierr /= 0) return
        if (.not. allocated(lu%rowind)) allocate (lu%rowind(a%nnz), stat=ierr)
        if (ierr /= 0) return
        lu%colptr = a%colptr(1:a%n + 1)
        lu%rowind = a%rowind(1:a%nnz)
    end subroutine store_pattern

    !> The lu_solve workspace w(n).
    pure subroutine ensure_workspace(lu, n, ierr)
        type(lu_t), intent(inout) :: lu   !! factors
        integer, intent(in) :: n          !! matrix size
        integer, intent(out) :: ierr      !! allocation status
        ierr = 0
        if (allocated(lu%w)) then
            if (size(lu%w) /= n) deallocate (lu%w)
        end if
        if (.not. allocated(lu%w)) allocate (lu%w(n), stat=ierr)
    end subroutine ensure_workspace
end module umfpack
