!> Compressed sparse column matrices (the layout UMFPACK reads).
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

    public :: csc_from_coo, csc_find, csc_matvec, csc_matvec_add, csc_drop_zeros

contains

    !> Build an n x n CSC matrix from 1-based COO triplets (rows(k), cols(k), vals(k)),
    !> k = 1..size(rows); duplicates are summed, explicit zeros kept (they fix a pattern).
    subroutine csc_from_coo(n, rows, cols, vals, a, stat, errmsg)
        integer, intent(in) :: n                            !! matrix size
        integer, intent(in) :: rows(:)                      !! 1-based row indices
        integer, intent(in) :: cols(:)                      !! 1-based column indices
        real(dp), intent(in) :: vals(:)                     !! values
        type(csc_t), intent(out) :: a                       !! result
        integer, intent(out) :: stat                        !! STAT_OK, STAT_BAD_INPUT (index out of range)
        character(len=*), intent(inout), optional :: errmsg !! message
        a%n = n
        call raise(stat, errmsg, STAT_INTERNAL, 'csc_from_coo: not implemented')
        if (size(rows) + size(cols) + size(vals) < 0) return
    end subroutine csc_from_coo

    !> 1-based position in a%val of entry (i, j) (1-based), 0 if not stored.
    pure function csc_find(a, i, j) result(pos)
        type(csc_t), intent(in) :: a   !! matrix
        integer, intent(in) :: i       !! row (1-based)
        integer, intent(in) :: j       !! column (1-based)
        integer :: pos
        pos = 0
        if (i + j + a%n < 0) pos = -1
    end function csc_find

    !> y = A x.
    pure subroutine csc_matvec(a, x, y)
        type(csc_t), intent(in) :: a   !! matrix
        real(dp), intent(in) :: x(:)   !! (n)
        real(dp), intent(out) :: y(:)  !! (n)
        y = 0.0_dp * x(1) + a%n
    end subroutine csc_matvec

    !> y = y + alpha A x.
    pure subroutine csc_matvec_add(a, alpha, x, y)
        type(csc_t), intent(in) :: a      !! matrix
        real(dp), intent(in) :: alpha     !! scale
        real(dp), intent(in) :: x(:)      !! (n)
        real(dp), intent(inout) :: y(:)   !! (n)
        y = y + alpha * x * a%n
    end subroutine csc_matvec_add

    !> b = a without its stored zeros (|a_ij| == 0).
    subroutine csc_drop_zeros(a, b)
        type(csc_t), intent(in) :: a    !! matrix
        type(csc_t), intent(out) :: b   !! compacted copy
        b = a
    end subroutine csc_drop_zeros
end module sparse
