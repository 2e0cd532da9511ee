!> Unit tests of module text: integers of both kinds, reals in ES form with a 3-digit
!> exponent (the E kept for |exponent| >= 100), given digits, the shortest form that
!> reads back; fixed-point text with its leading zero. Exit status 1 (error stop) on any
!> failure.
program test_text
    use kinds, only: dp, i8
    use text, only: int_text, real_text, fixed_text
    use unit_checks, only: checks_t
    implicit none
    type(checks_t) :: checks
    real(dp) :: y
    character(len=:), allocatable :: third

    call checks%check(int_text(42) == '42', 'int_text default')
    call checks%check(int_text(-7) == '-7', 'int_text negative')
    call checks%check(int_text(9000000000_i8) == '9000000000', 'int_text 64-bit')
    call checks%check(real_text(2.225e-307_dp, 4) == '2.225E-307', '3-digit exponent kept')
    call checks%check(real_text(1.5_dp, 6) == '1.50000E+000', 'given digits')
    call checks%check(real_text(-3.14159265_dp, 6) == '-3.14159E+000', 'negative, no overflow')
    call checks%check(real_text(0.1_dp) == '1.0E-001', 'shortest form of 0.1')
    third = real_text(1.0_dp / 3.0_dp)
    read (third, *) y
    call checks%check(y == 1.0_dp / 3.0_dp, 'the shortest form reads back exactly')
    call checks%check(fixed_text(0.85_dp, 3) == '0.850', 'fixed: leading zero below 1')
    call checks%check(fixed_text(-0.5_dp, 1) == '-0.5', 'fixed: negative below 1')
    call checks%check(fixed_text(1.666_dp, 3) == '1.666', 'fixed: above 1')
    call checks%check(fixed_text(125.04_dp, 1) == '125.0', 'fixed: rounded')
    call checks%check(fixed_text(0.0_dp, 2) == '0.00', 'fixed: zero')
    ! (freed: a leak checker counts what the program still holds at its end as lost)
    deallocate (third)
    call checks%finish('test_text')
end program test_text
