!> UMFPACK (SuiteSparse) binding through ISO_C_BINDING: LU factorization and
!> solves of csc_t matrices, handles kept in lu_t.
module umfpack
    use iso_c_binding, only: c_ptr, c_null_ptr, c_double, c_int
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_NUMERIC, STAT_INTERNAL, raise
    use sparse, only: csc_t
    implicit none
    private

    !> LU factors of one matrix (symbolic analysis kept across numeric refactorizations
    !> of the same pattern).
    type, public :: lu_t
        type(c_ptr) :: symbolic = c_null_ptr        !! UMFPACK symbolic object
        type(c_ptr) :: numeric = c_null_ptr         !! UMFPACK numeric object
        integer :: n = 0                            !! size factorized
        integer :: factorizations = 0               !! numeric factorizations done
        real(c_double) :: control(20) = 0.0_dp      !! UMFPACK control (defaults, no iterative refinement)
        real(c_double) :: info(90) = 0.0_dp         !! UMFPACK info of the last call
        integer(c_int), allocatable :: wi(:)        !! wsolve integer workspace
        real(c_double), allocatable :: w(:)         !! wsolve real workspace
    end type lu_t

    public :: lu_factor, lu_solve, lu_free

contains

    !> Factorize A (symbolic once per pattern, numeric every call). A singular matrix
    !> (UMFPACK status +1) gives STAT_NUMERIC "singular matrix"; other negative statuses
    !> STAT_INTERNAL with UMFPACK's status number.
    subroutine lu_factor(lu, a, stat, errmsg)
        type(lu_t), intent(inout) :: lu                    !! factors (created or replaced)
        type(csc_t), intent(in) :: a                        !! matrix
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        lu%n = a%n
        call raise(stat, errmsg, STAT_INTERNAL, 'lu_factor: not implemented')
    end subroutine lu_factor

    !> Solve A x = b with the factors of A (no allocation, no iterative refinement).
    subroutine lu_solve(lu, a, b, x, stat, errmsg)
        type(lu_t), intent(inout) :: lu                     !! factors of a
        type(csc_t), intent(in) :: a                        !! the factorized matrix
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(out) :: x(:)                       !! solution (n)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        x = b * a%n
        lu%n = lu%n
        call raise(stat, errmsg, STAT_INTERNAL, 'lu_solve: not implemented')
    end subroutine lu_solve

    !> Release the UMFPACK objects and workspaces.
    subroutine lu_free(lu)
        type(lu_t), intent(inout) :: lu   !! factors to release
        lu%n = 0
    end subroutine lu_free
end module umfpack
