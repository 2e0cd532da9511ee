!> Building a model raises no floating-point exception: with the penalty and the augmented
!> Lagrangian (no element bound on gamma0, gamma0_min = 0) as with Nitsche's method, in 1D,
!> 2D and 3D, model_build signals neither division by zero, nor an invalid operation, nor
!> an overflow (the suggested gamma0 of its messages must not take log10 of that 0). The IEEE
!> flags are read, so this holds in a build that does not trap them (the checked build of
!> scripts/checked traps them). Exit status 1 (error stop) on any failure.
program test_model_fp_flags
    use, intrinsic :: ieee_exceptions, only: ieee_get_flag, ieee_set_flag, ieee_all, &
        ieee_divide_by_zero, ieee_invalid, ieee_overflow
    use kinds, only: dp
    use mesh, only: mesh_t
    use bar_mesh, only: bar_mesh_build
    use model, only: model_t, model_params_t, model_build
    use alm_contact, only: ALM_INTEGRAL
    use unit_checks, only: checks_t
    implicit none
    type(checks_t) :: checks
    integer :: dim, method
    character(len=*), parameter :: NAMES(3) = [character(len=7) :: 'nitsche', 'penalty', 'alm']

    do dim = 1, 3
        do method = 1, 3
            call check_build(dim, method)
        end do
    end do
    call checks%finish('test_model_fp_flags')

contains

    subroutine check_build(dim, method)
        integer, intent(in) :: dim, method
        type(mesh_t) :: msh
        type(model_params_t) :: prm
        type(model_t) :: mdl
        integer :: stat
        logical :: zero, invalid, overflow
        character(len=256) :: msg
        character(len=40) :: tag
        write (tag, '(a, i0, a)') ' (', dim, 'D '//trim(NAMES(method))//')'
        call bar_mesh_build(dim, 1.0_dp, 0.1_dp, 0.05_dp, msh, stat, msg)
        call checks%check(stat == 0, 'mesh'//trim(tag))
        prm%clamped = 'top'; prm%contact = 'bottom'
        prm%young = 2.0_dp / 3.0_dp; prm%poisson = 1.0_dp / 3.0_dp
        prm%gamma0 = 10.0_dp
        prm%penalty = method == 2
        if (method == 3) prm%multiplier = ALM_INTEGRAL
        select case (dim)
        case (1)
            prm%obstacle_normal = [-1.0_dp, 0.0_dp, 0.0_dp]; prm%probe = 0.0_dp
        case (2)
            prm%obstacle_normal = [0.0_dp, -1.0_dp, 0.0_dp]; prm%probe = [0.05_dp, 0.0_dp, 0.0_dp]
        case default
            prm%obstacle_normal = [0.0_dp, 0.0_dp, -1.0_dp]; prm%probe = [0.05_dp, 0.05_dp, 0.0_dp]
        end select
        call ieee_set_flag(ieee_all, .false.)
        call model_build(msh, prm, mdl, stat, msg)
        call ieee_get_flag(ieee_divide_by_zero, zero)
        call ieee_get_flag(ieee_invalid, invalid)
        call ieee_get_flag(ieee_overflow, overflow)
        call checks%check(stat == 0, 'model builds'//trim(tag)//': '//trim(msg))
        call checks%check(.not. zero, 'no division by zero'//trim(tag))
        call checks%check(.not. invalid, 'no invalid operation'//trim(tag))
        call checks%check(.not. overflow, 'no overflow'//trim(tag))
    end subroutine check_build

end program test_model_fp_flags
