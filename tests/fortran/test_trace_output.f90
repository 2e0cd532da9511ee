!> trace_output: a trace row is the same text as the Fortran edit descriptors
!> '(8(es24.16e3, ","), i0, ",", i0, 2(",", es24.16e3))' (the C fast path of run_guard.c
!> against libgfortran's formatted output), for random values over the whole range of
!> exponents, more of them between 1e-30 and 1e-5 (the fast path's two-step scaling),
!> rounding boundaries, signed zeros and non-finite values (f_n, the last column, is
!> given -e_load: the same values, the other sign); but for a value that is not finite,
!> written nan, inf or -inf without blanks (the text pandas reads as a number).
program test_trace_output
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf, &
                                             ieee_negative_inf, ieee_is_finite, ieee_is_nan
    use, intrinsic :: ieee_exceptions, only: ieee_get_halting_mode, ieee_set_halting_mode, &
                                             ieee_overflow
    use kinds, only: dp
    use trace_output, only: trace_t, trace_open, trace_row, trace_close
    implicit none
    integer, parameter :: N_RANDOM = 200000   ! random rows
    integer, parameter :: N_SMALL = 50000     ! random rows with exponents in [-30, -5]
    integer, parameter :: N_FIXED = 13        ! rows of special values
    integer :: fails, i, st, unit, ios, k
    logical :: halting
    real(dp) :: v(9), r(2)
    character(len=400) :: line, expect
    type(trace_t) :: tr
    real(dp), allocatable :: vals(:, :)
    integer, allocatable :: ints(:, :)
    character(len=*), parameter :: path = 'test_trace_output.csv'

    allocate (vals(9, N_RANDOM + N_FIXED + N_SMALL), ints(2, N_RANDOM + N_FIXED + N_SMALL))
    ! exponents above 308 overflow to +-infinity, which the trace writes as well: meant,
    ! so not trapped where the build traps overflows (scripts/checked)
    call ieee_get_halting_mode(ieee_overflow, halting)
    call ieee_set_halting_mode(ieee_overflow, .false.)
    do i = 1, N_RANDOM
        do k = 1, 9
            call random_number(r)
            ! mantissa in [1, 10), exponent in [-320, 310], either sign
            vals(k, i) = sign(1.0_dp, r(1) - 0.5_dp) * (1.0_dp + 9.0_dp * r(2)) * &
                         10.0_dp**(int(631.0_dp * r(1)) - 320)
        end do
        ints(:, i) = [i - N_RANDOM / 2, mod(i, 7)]
    end do
    call ieee_set_halting_mode(ieee_overflow, halting)
    ! special values: zeros, decade boundaries, ties in the 17th digit, huge, tiny, NaN, inf
    vals(:, N_RANDOM + 1) = [0.0_dp, -0.0_dp, 1.0_dp, 10.0_dp, 0.1_dp, 9.99999999999999999_dp, &
                             0.5_dp, 0.125_dp, 1.0e22_dp]
    vals(:, N_RANDOM + 2) = [huge(1.0_dp), tiny(1.0_dp), -huge(1.0_dp), 1.0e-310_dp, 5.0e-324_dp, &
                             12345678901234567.0_dp, 123456789012345678.0_dp, 2.5e17_dp, 1.0e23_dp]
    vals(:, N_RANDOM + 3) = [ieee_value(1.0_dp, ieee_quiet_nan), ieee_value(1.0_dp, ieee_positive_inf), &
                             ieee_value(1.0_dp, ieee_negative_inf), 9007199254740993.0_dp, &
                             0.3_dp, 2.0_dp / 3.0_dp, 1.0_dp / 3.0_dp, 1.0e-5_dp, 99999999999999999.0_dp]
    do i = N_RANDOM + 4, N_RANDOM + 8
        do k = 1, 9
            ! values near ties: integers and halves times powers of ten
            vals(k, i) = (real(k + 10 * i, dp) + 0.5_dp) * 10.0_dp**(k - 5)
        end do
        ints(:, i) = [0, -1]
    end do
    do i = N_RANDOM + 9, N_RANDOM + 13
        do k = 1, 9
            ! the same near small powers of ten (exponents -28 to -8)
            vals(k, i) = (real(k + 10 * i, dp) + 0.5_dp) * 10.0_dp**(k - 5 - 3 * (i - N_RANDOM - 5))
        end do
        ints(:, i) = [1, -2]
    end do
    do i = N_RANDOM + N_FIXED + 1, size(vals, 2)
        do k = 1, 9
            call random_number(r)
            vals(k, i) = sign(1.0_dp, r(1) - 0.5_dp) * (1.0_dp + 9.0_dp * r(2)) * &
                         10.0_dp**(int(26.0_dp * r(1)) - 30)
        end do
        ints(:, i) = [i, -i]
    end do
    ints(:, N_RANDOM + 1:N_RANDOM + 3) = reshape([0, 0, 123, 4567, -2147483647, 2147483647], [2, 3])

    call trace_open(path, tr, st)
    if (st /= 0) error stop 'cannot open the trace'
    do i = 1, size(vals, 2)
        v = vals(:, i)
        call trace_row(tr, v(1), v(2), v(3), v(4), v(5), v(6), v(7), v(8), ints(1, i), ints(2, i), &
                       v(9), -v(9), st)
        if (st /= 0) error stop 'trace_row failed'
    end do
    call trace_close(tr, st)
    if (st /= 0) error stop 'trace_close failed'

    fails = 0
    open (newunit=unit, file=path, status='old', action='read')
    read (unit, '(a)') line
    do i = 1, size(vals, 2)
        read (unit, '(a)', iostat=ios) line
        if (ios /= 0) error stop 'trace too short'
        v = vals(:, i)
        expect = ''
        do k = 1, 8
            expect = trim(expect)//field(v(k))//','
        end do
        write (expect(len_trim(expect) + 1:), '(i0, ",", i0, ",")') ints(:, i)
        expect = trim(expect)//field(v(9))//','//field(-v(9))
        if (line /= expect) then
            fails = fails + 1
            if (fails <= 5) then
                print '(a)', 'row:      '//trim(line)
                print '(a)', 'expected: '//trim(expect)
            end if
        end if
    end do
    close (unit, status='delete')
    if (fails > 0) then
        print '(i0, a)', fails, ' rows differ'
        error stop 1
    end if
    print '(a, i0, a)', 'test_trace_output: ', size(vals, 2), ' rows identical'
    ! (freed: a leak checker counts what the program still holds at its end as lost)
    deallocate (vals, ints)
contains
    !> x as es24.16e3, or nan, inf, -inf when it is not finite.
    function field(x) result(s)
        real(dp), intent(in) :: x   !! value
        character(len=:), allocatable :: s
        character(len=24) :: buf
        if (ieee_is_nan(x)) then
            s = 'nan'
        else if (.not. ieee_is_finite(x)) then
            s = merge('inf ', '-inf', x > 0.0_dp)
            s = trim(s)
        else
            write (buf, '(es24.16e3)') x
            s = buf
        end if
    end function field
end program test_trace_output
