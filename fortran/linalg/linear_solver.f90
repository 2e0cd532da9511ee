!> Direct solves of csc_t matrices for the time schemes: symmetric positive definite
!> matrices with CHOLMOD's simplicial LDL^T (about half the factor entries and half
!> the solve time of an LU), anything else with UMFPACK's LU.
!>
!> ls_factor tries LDL^T when the matrix is symmetric (to SYM_RTOL) and falls back to
!> UMFPACK when it is not, or when LDL^T meets a zero, negative or non-finite pivot
!> (an indefinite J0 = M + c K_theta, e.g. small gamma0 with Nitsche theta = 1: the
!> schemes need an exact solve, so this is not an error). f%backend records which
!> one holds the factors. A factor_t owns C pointers: never copy one by assignment.
module linear_solver
    use kinds, only: dp, i8
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, raise
    use sparse, only: csc_t, csc_find
    use umfpack, only: lu_t, lu_factor, lu_solve, lu_solve_many, lu_free
    use cholmod, only: cholmod_t, chol_factor, chol_solve, chol_solve_many, chol_free, chol_kernel, &
                       chol_ordering
    implicit none
    private

    !> Asymmetry accepted as assembly round-off: |a_ij - a_ji| <= SYM_RTOL s_ij with
    !> s_ij = max(|a_ij| + |a_ji|, sqrt(|a_ii a_jj|)) (the pair's own size, or the
    !> diagonal scale that bounds it in an SPD matrix, for entries that nearly cancel).
    !> LDL^T then reads the upper triangle. The h = 0.01 seed J0 has 7e-20; a
    !> non-symmetric Nitsche term (theta /= 1) is many orders larger.
    real(dp), parameter, public :: SYM_RTOL = 1.0e-14_dp

    character(len=*), parameter, public :: BACKEND_CHOLMOD = 'cholmod_ldlt'  !! LDL^T ran
    character(len=*), parameter, public :: BACKEND_UMFPACK = 'umfpack_lu'    !! LU ran

    !> Factors of one matrix and the backend that computed them.
    type, public :: factor_t
        character(len=16) :: backend = ''       !! BACKEND_CHOLMOD, BACKEND_UMFPACK, '' (none)
        logical :: symmetric = .false.          !! the last matrix factorized was symmetric
        logical :: fell_back = .false.          !! symmetric, but LDL^T met a bad pivot
        integer :: n = 0                        !! size factorized (0: no factors)
        integer :: factorizations = 0           !! successful factorizations (kept by ls_free)
        type(cholmod_t) :: ch                   !! LDL^T factors
        type(lu_t) :: lu                        !! LU factors
    end type factor_t

    public :: ls_factor, ls_solve, ls_solve_many, ls_free, ls_kernel, ls_factor_info, &
              csc_is_symmetric

contains

    !> Factorize a: LDL^T if symmetric and positive definite, UMFPACK LU otherwise.
    !> Errors are those of the LU (STAT_NUMERIC 'singular matrix', STAT_BAD_INPUT for
    !> inconsistent arrays, STAT_INTERNAL); an LDL^T error other than a bad pivot is
    !> returned as is.
    subroutine ls_factor(f, a, stat, errmsg)
        type(factor_t), intent(inout) :: f                  !! factors (created or replaced)
        type(csc_t), intent(in) :: a                        !! matrix
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        f%backend = ''
        f%n = 0
        f%fell_back = .false.
        f%symmetric = csc_is_symmetric(a)
        if (f%symmetric) then
            call chol_factor(f%ch, a, stat, errmsg)
            if (stat == STAT_OK) then
                call lu_free(f%lu)
                f%backend = BACKEND_CHOLMOD
                f%n = a%n
                f%factorizations = f%factorizations + 1
                return
            end if
            if (stat /= STAT_NUMERIC) return
            f%fell_back = .true.
        end if
        call chol_free(f%ch)
        call lu_factor(f%lu, a, stat, errmsg)
        if (stat /= STAT_OK) return
        f%backend = BACKEND_UMFPACK
        f%n = a%n
        f%factorizations = f%factorizations + 1
    end subroutine ls_factor

    !> Solve A x = b with the factors of a (no allocation). b and x must have n entries.
    subroutine ls_solve(f, a, b, x, stat, errmsg)
        type(factor_t), intent(inout) :: f                  !! factors of a
        type(csc_t), intent(in) :: a                        !! the factorized matrix
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(out) :: x(:)                       !! solution (n)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        if (f%n /= a%n .or. f%n < 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'ls_solve: no factors of this matrix')
            return
        end if
        if (f%backend == BACKEND_CHOLMOD) then
            call chol_solve(f%ch, b, x, stat, errmsg)
        else
            call lu_solve(f%lu, a, b, x, stat, errmsg)
        end if
    end subroutine ls_solve

    !> Solve A X = B for the columns of B (CHOLMOD: one blocked solve, or column after
    !> column with the factor by node blocks; UMFPACK: one column after the other).
    subroutine ls_solve_many(f, a, b, x, stat, errmsg)
        type(factor_t), intent(inout) :: f                  !! factors of a
        type(csc_t), intent(in) :: a                        !! the factorized matrix
        real(dp), intent(in) :: b(:, :)                     !! right-hand sides (n, m)
        real(dp), intent(out) :: x(:, :)                    !! solutions (n, m)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        if (size(b, 2) /= size(x, 2)) then
            call raise(stat, errmsg, STAT_BAD_INPUT, &
                       'ls_solve_many: b and x have different numbers of columns')
            return
        end if
        if (f%n /= a%n .or. f%n < 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'ls_solve_many: no factors of this matrix')
            return
        end if
        if (f%backend == BACKEND_CHOLMOD) then
            call chol_solve_many(f%ch, b, x, stat, errmsg)
        else
            call lu_solve_many(f%lu, a, b, x, stat, errmsg)
        end if
    end subroutine ls_solve_many

    !> The triangular solve ls_solve runs: 'ldl_node_pairs' (LDL^T by 2x2 node blocks),
    !> 'cholmod_solve2', 'umfpack' ('' without factors).
    pure function ls_kernel(f) result(name)
        type(factor_t), intent(in) :: f      !! factors
        character(len=:), allocatable :: name
        if (f%n < 1) then
            name = ''
        else if (f%backend == BACKEND_CHOLMOD) then
            name = chol_kernel(f%ch)
        else
            name = 'umfpack'
        end if
    end function ls_kernel

    !> The fill-reducing ordering of the LDL^T factors ('amd', 'metis', 'nesdis',
    !> 'cholmod'; 'umfpack' for the LU, whose ordering is UMFPACK's own; '' without
    !> factors) and the entries stored in the LDL^T factor (D and L; 0 for the LU).
    subroutine ls_factor_info(f, ordering, nnz)
        type(factor_t), intent(in) :: f                      !! factors
        character(len=:), allocatable, intent(out) :: ordering  !! ordering's name
        integer(i8), intent(out) :: nnz                      !! stored entries
        ordering = ''
        nnz = 0
        if (f%n < 1) return
        if (f%backend == BACKEND_CHOLMOD) then
            ordering = chol_ordering(f%ch)
            nnz = int(f%ch%factor_nnz, i8)
        else
            ordering = 'umfpack'
        end if
    end subroutine ls_factor_info

    !> Release both backends' factors (safe to call twice). The counter is kept.
    subroutine ls_free(f)
        type(factor_t), intent(inout) :: f   !! factors to release
        call chol_free(f%ch)
        call lu_free(f%lu)
        f%n = 0
    end subroutine ls_free

    !> a has a symmetric pattern (entries stored without a partner must be zero) and
    !> values symmetric to SYM_RTOL (n >= 1, CSC arrays allocated; .false. otherwise).
    pure function csc_is_symmetric(a) result(sym)
        type(csc_t), intent(in) :: a   !! matrix
        logical :: sym
        integer :: i, j, k, p
        real(dp) :: s
        sym = .false.
        if (a%n < 1 .or. .not. (allocated(a%colptr) .and. allocated(a%rowind) .and. &
                                allocated(a%val))) return
        if (size(a%colptr) < a%n + 1) return
        if (a%colptr(a%n + 1) /= a%nnz .or. size(a%rowind) < a%nnz .or. size(a%val) < a%nnz) &
            return
        do j = 1, a%n
            do k = a%colptr(j) + 1, a%colptr(j + 1)
                i = a%rowind(k) + 1
                if (i == j) cycle
                p = csc_find(a, j, i)
                if (p == 0) then
                    if (a%val(k) /= 0.0_dp) return
                else if (i < j) then
                    s = max(abs(a%val(k)) + abs(a%val(p)), sqrt(abs(diag(i) * diag(j))))
                    if (abs(a%val(k) - a%val(p)) > SYM_RTOL * s) return
                end if
            end do
        end do
        sym = .true.
    contains
        !> a_ii (0 if not stored).
        pure real(dp) function diag(ii)
            integer, intent(in) :: ii   !! row = column (1-based)
            integer :: q
            q = csc_find(a, ii, ii)
            diag = 0.0_dp
            if (q > 0) diag = a%val(q)
        end function diag
    end function csc_is_symmetric
end module linear_solver
