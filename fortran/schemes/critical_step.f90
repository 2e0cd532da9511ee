!> The largest natural frequency omega_max of the linearized model, which bounds the
!> step of every explicit scheme: dt_crit = Omega_c / omega_max, Omega_c the stability
!> limit of the scheme's amplification matrix on one mode M u'' = -omega^2 M u (2 for
!> central differences, sqrt(2) for pc; explicit_schemes.f90 for the pc family).
!>
!> omega_max^2 is the largest eigenvalue of M^{-1} (K_theta + D_full), D_full the contact
!> tangent with every contact quadrature point active (a deep uniform penetration, the
!> stiffest state the contact can reach), found by power iteration from a fixed start
!> vector. Power iteration approaches omega_max^2 from below, so the dt_crit it gives is
!> from above: a step above the estimate is above the linear limit.
module critical_step
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_NUMERIC, raise
    use model, only: model_t, model_apply_jacobian
    use mass_solver, only: mass_solver_t, mass_solver_apply
    use stop_signal, only: check_stop
    implicit none
    private

    !> The fraction of the estimate an explicit run is advised (and central's dt = 0
    !> takes): power iteration estimates dt_crit from above, and the contact is nonlinear.
    real(dp), parameter, public :: CRITICAL_SAFETY = 0.9_dp
    integer, parameter :: POWER_ITERATIONS = 200             !! power iterations for omega_max

    public :: omega_max_squared, critical_dt

contains

    !> The critical step Omega_c / omega_max of an explicit scheme whose one-mode stability
    !> limit of omega dt is omega_c (2 for central differences; pc_stability_limit for the
    !> pc family), omega_max at full contact (omega_max_squared). 0 when omega_c is (no
    !> step is stable: nothing is computed) or there are no free dofs.
    subroutine critical_dt(mdl, ms, omega_c, who, dt_crit, stat, errmsg)
        type(model_t), intent(in) :: mdl                    !! model
        type(mass_solver_t), intent(inout) :: ms            !! M^{-1}
        real(dp), intent(in) :: omega_c                     !! the scheme's limit of omega dt
        character(len=*), intent(in) :: who                 !! scheme's name, for the message
        real(dp), intent(out) :: dt_crit                    !! omega_c / omega_max
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: lam
        stat = STAT_OK
        dt_crit = 0.0_dp
        if (.not. omega_c > 0.0_dp) return
        call omega_max_squared(mdl, ms, who, lam, stat, errmsg)
        if (stat /= STAT_OK) return
        if (lam > 0.0_dp) dt_crit = omega_c / sqrt(lam)
    end subroutine critical_dt

    !> omega_max^2, the largest eigenvalue of M^{-1} (K_theta + D_full) (module header),
    !> by POWER_ITERATIONS power iterations, each one Jacobian product and one M^{-1}
    !> application. 0 when there are no free dofs. A set-up's work: the stop flag is read
    !> before each iteration (module stop_signal), STAT_INTERRUPTED when it is set.
    subroutine omega_max_squared(mdl, ms, who, lam, stat, errmsg)
        type(model_t), intent(in) :: mdl                    !! model
        type(mass_solver_t), intent(inout) :: ms            !! M^{-1}
        character(len=*), intent(in) :: who                 !! scheme's name, for the message
        real(dp), intent(out) :: lam                        !! omega_max^2 (from below)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), allocatable :: x(:), y(:), upen(:)
        real(dp) :: nrm, extent
        integer :: it, i, n
        stat = STAT_OK
        lam = 0.0_dp
        n = mdl%n_dofs
        if (n == 0) return
        allocate (x(n), y(n), upen(n))
        ! a uniform penetration far beyond any strain the mesh can show: every contact
        ! quadrature point is active there
        extent = 1.0e6_dp * max(1.0_dp, maxval(abs(mdl%msh%x)))
        do i = 1, n
            upen(i) = extent * mdl%normal(mdl%dof_comp(i))
            x(i) = 1.0_dp + real(mod(7 * i, 11), dp) / 11.0_dp   ! fixed, generic start
        end do
        x = x / norm2(x)
        do it = 1, POWER_ITERATIONS
            call check_stop('the critical step estimate', stat, errmsg)   ! a set-up's work
            if (stat /= STAT_OK) return
            call model_apply_jacobian(mdl, upen, x, y)
            call mass_solver_apply(ms, y, x, stat, errmsg)
            if (stat /= STAT_OK) return
            nrm = norm2(x)
            if (.not. (nrm > 0.0_dp .and. nrm <= huge(nrm))) then
                call raise(stat, errmsg, STAT_NUMERIC, &
                           who//': the critical step estimate failed (M^-1 K not finite)')
                return
            end if
            lam = nrm
            x = x / nrm
        end do
    end subroutine omega_max_squared
end module critical_step
