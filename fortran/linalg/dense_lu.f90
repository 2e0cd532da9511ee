!> Small dense LU with partial pivoting (the contact correction systems: up to a few
!> hundred unknowns in 3D).
module dense_lu
    use kinds, only: dp
    implicit none
    private
    public :: dense_lu_factor, dense_lu_solve

contains

    !> In-place LU factorization with partial pivoting of the leading n x n block.
    !> info = 0 on success, k > 0 if the pivot of column k is zero.
    !> By panels of NB columns: a panel is factorized column after column as in the
    !> textbook right-looking loop (pivot, row interchange over the whole rows, scaling,
    !> updates of the panel's later columns), and then each column on its right gets the
    !> panel's NB updates in one pass (a(i, j) - l(i, k) u(k, j) for k = 1..NB in that
    !> order, the row interchanges commuting with the updates they overtake): the same
    !> operations on the same numbers as the column-by-column loop, so the same factors
    !> to the bit, with the trailing columns read once a panel instead of once a column.
    pure subroutine dense_lu_factor(n, a, piv, info)
        integer, intent(in) :: n              !! order
        real(dp), intent(inout), contiguous :: a(:, :)  !! matrix in, L\U out (leading n x n)
        integer, intent(out) :: piv(:)        !! (n) row interchanges
        integer, intent(out) :: info          !! 0 or the first zero pivot
        integer, parameter :: NB = 4
        integer :: j, k, p, kb, ke
        real(dp) :: tmp
        info = 0
        do kb = 1, n, NB
            ke = min(kb + NB - 1, n)
            do k = kb, ke
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
                do j = k + 1, ke
                    a(k + 1:n, j) = a(k + 1:n, j) - a(k + 1:n, k) * a(k, j)
                end do
            end do
            do j = ke + 1, n
                call panel_update(n, kb, ke, a, j)
            end do
        end do
    end subroutine dense_lu_factor

    !> Column j (right of the panel kb..ke) gets the panel's updates: rows kb+1..ke
    !> pivot after pivot (the triangle: each row's u(k, j) is needed by the next
    !> pivot; written out for a full panel, where loops of 1 to 3 rows cost more than
    !> their work, and kept in scalars for the next pass), then rows ke+1..n all ke-kb+1
    !> updates in one pass, in pivot order.
    pure subroutine panel_update(n, kb, ke, a, j)
        integer, intent(in) :: n, kb, ke, j   !! order, panel, column
        real(dp), intent(inout), contiguous :: a(:, :)  !! factors so far
        real(dp) :: u1, u2, u3, u4
        integer :: i, k
        if (ke - kb == 3) then
            ! (u(k, j) in scalars: the pass below then reads no entry of column j it writes)
            u1 = a(kb, j)
            u2 = a(kb + 1, j) - a(kb + 1, kb) * u1
            u3 = a(kb + 2, j) - a(kb + 2, kb) * u1
            u4 = a(kb + 3, j) - a(kb + 3, kb) * u1
            u3 = u3 - a(kb + 2, kb + 1) * u2
            u4 = u4 - a(kb + 3, kb + 1) * u2
            u4 = u4 - a(kb + 3, kb + 2) * u3
            a(kb + 1, j) = u2
            a(kb + 2, j) = u3
            a(kb + 3, j) = u4
            do i = ke + 1, n
                a(i, j) = (((a(i, j) - a(i, kb) * u1) - a(i, kb + 1) * u2) &
                           - a(i, kb + 2) * u3) - a(i, kb + 3) * u4
            end do
        else
            do k = kb, ke - 1
                a(k + 1:ke, j) = a(k + 1:ke, j) - a(k + 1:ke, k) * a(k, j)
            end do
            do k = kb, ke
                a(ke + 1:n, j) = a(ke + 1:n, j) - a(ke + 1:n, k) * a(k, j)
            end do
        end if
    end subroutine panel_update

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
