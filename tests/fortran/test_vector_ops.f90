!> Unit tests of module vector_ops: `dot` against exact and bounded references at lengths
!> around multiples of LANES (its vector part, its tail, both); it reads size(a) entries
!> of a longer b, and dot(a, b) = dot(b, a) bit for bit.
!> Exit status 1 (error stop) on any failure.
program test_vector_ops
    use kinds, only: dp, i8
    use vector_ops, only: dot, LANES
    use unit_checks, only: checks_t, seed
    implicit none
    integer, parameter :: qp = selected_real_kind(30)
    type(checks_t) :: checks
    integer :: t, n, i
    integer :: lengths(12)
    integer(i8) :: exact
    real(dp), allocatable :: a(:), b(:)
    real(qp) :: ref, bound
    character(len=16) :: tag

    lengths = [0, 1, 3, LANES - 1, LANES, LANES + 1, 2 * LANES + 3, 63, 64, 65, 2200, 2207]
    call seed(11)
    do t = 1, size(lengths)
        n = lengths(t)
        write (tag, '(a,i0)') ' n = ', n
        allocate (a(n), b(n + 5))
        ! small integers: every partial sum is an integer below 2^53, so the sum is exact
        ! whatever the order of the additions
        exact = 0
        do i = 1, n
            a(i) = real(mod(7 * i, 13) - 6, dp)
            b(i) = real(mod(5 * i, 11) - 5, dp)
            exact = exact + int(a(i), i8) * int(b(i), i8)
        end do
        b(n + 1:) = 1.0e300_dp   ! beyond size(a): never read
        call checks%check(dot(a, b) == real(exact, dp), 'dot exact on integers,'//trim(tag))
        ! random values: within the textbook bound n eps sum |a_i b_i| of a sum in
        ! quadruple precision
        call random_number(a)
        call random_number(b)
        a = a - 0.5_dp
        b(1:n) = b(1:n) - 0.5_dp
        ref = 0.0_qp
        bound = 0.0_qp
        do i = 1, n
            ref = ref + real(a(i), qp) * real(b(i), qp)
            bound = bound + abs(real(a(i), qp) * real(b(i), qp))
        end do
        bound = real(n + 1, qp) * real(epsilon(1.0_dp), qp) * bound
        call checks%check(abs(real(dot(a, b), qp) - ref) <= bound, &
                          'dot within n eps sum |a b|,'//trim(tag))
        call checks%check(dot(a, b) == dot(a, b(1:n)), 'dot reads size(a) entries,'//trim(tag))
        call checks%check(dot(a, b(1:n)) == dot(b(1:n), a), 'dot symmetric,'//trim(tag))
        deallocate (a, b)
    end do
    call checks%finish('test_vector_ops')
end program test_vector_ops
