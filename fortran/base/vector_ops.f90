!> Reductions over long vectors at the speed of their loads: each sum is kept in LANES
!> independent partial sums (the loop vectorizes and is not bound by the latency of one
!> chain of adds), added in a fixed order at the end, so a result is the same from run to
!> run; it differs from a single left-to-right sum by round-off only.
module vector_ops
    use kinds, only: dp
    implicit none
    private

    !> Partial sums of a reduction: 16, four 4-wide vector chains at x86-64-v3 (one chain,
    !> LANES = 4, is bound by the latency of its adds: 3 cycles a vector).
    integer, parameter, public :: LANES = 16

    public :: dot, lane_sum

contains

    !> a . b (size(b) >= size(a)).
    pure function dot(a, b) result(s)
        real(dp), intent(in), contiguous :: a(:)    !! first vector
        real(dp), intent(in), contiguous :: b(:)    !! second vector
        real(dp) :: s
        real(dp) :: acc(LANES)
        integer :: i, j, n, nb
        n = size(a)
        nb = n - mod(n, LANES)
        acc = 0.0_dp
        do i = 1, nb, LANES
            do j = 1, LANES
                acc(j) = acc(j) + a(i + j - 1) * b(i + j - 1)
            end do
        end do
        do i = nb + 1, n
            acc(1) = acc(1) + a(i) * b(i)
        end do
        s = lane_sum(acc)
    end function dot

    !> The partial sums of a reduction added in a fixed order.
    pure function lane_sum(acc) result(s)
        real(dp), intent(in) :: acc(LANES)          !! partial sums
        real(dp) :: s
        integer :: j
        s = acc(1)
        do j = 2, LANES
            s = s + acc(j)
        end do
    end function lane_sum
end module vector_ops
