!> Small dense LU with partial pivoting (the contact correction systems, a few
!> dozen unknowns at most).
module dense_lu
    use kinds, only: dp
    implicit none
    private
    public :: dense_lu_factor, dense_lu_solve

contains

    !> In-place LU factorization with partial pivoting of the leading n x n block.
    !> info = 0 on success, k > 0 if the pivot of column k is zero.
    pure subroutine dense_lu_factor(n, a, piv, info)
        integer, intent(in) :: n              !! order
        real(dp), intent(inout), contiguous :: a(:, :)  !! matrix in, L\U out (leading n x n)
        integer, intent(out) :: piv(:)        !! (n) row interchanges
        integer, intent(out) :: info          !! 0 or the first zero pivot
        integer :: j, k, p
        real(dp) :: tmp
        info = 0
        do k = 1, n
            p = k - 1 + maxloc(abs(a(k:n, k)), dim=1)
            piv(k) = p
            if (a(p, k) == 0.0_dp) then
                info = k
                return
            end if
            if (p /= k) then   ! (element by element: no temporary row on the heap)
                do j = 1, n
                    tmp = a(k, j)
                    a(k, j) = a(p, j)
                    a(p, j) = tmp
                end do
            end if
            a(k + 1:n, k) = a(k + 1:n, k) / a(k, k)
            do j = k + 1, n
                a(k + 1:n, j) = a(k + 1:n, j) - a(k + 1:n, k) * a(k, j)
            end do
        end do
    end subroutine dense_lu_factor

    !> Solve A x = b with the factors of dense_lu_factor; b is overwritten by x.
    pure subroutine dense_lu_solve(n, a, piv, b)
        integer, intent(in) :: n              !! order
        real(dp), intent(in), contiguous :: a(:, :)  !! L\U factors
        integer, intent(in) :: piv(:)         !! row interchanges
        real(dp), intent(inout) :: b(:)       !! right-hand side in, solution out
        integer :: k
        real(dp) :: tmp
        do k = 1, n
            if (piv(k) /= k) then
                tmp = b(k); b(k) = b(piv(k)); b(piv(k)) = tmp
            end if
        end do
        do k = 1, n
            b(k + 1:n) = b(k + 1:n) - a(k + 1:n, k) * b(k)
        end do
        do k = n, 1, -1
            b(k) = b(k) / a(k, k)
            b(1:k - 1) = b(1:k - 1) - a(1:k - 1, k) * b(k)
        end do
    end subroutine dense_lu_solve
end module dense_lu
