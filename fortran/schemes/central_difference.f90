!> Explicit central differences (Newmark beta = 0, gamma = 1/2), scheme `central`:
!>     u' = u + dt v + dt^2/2 a,   a' = M^{-1} (L - B(u')),   v' = v + dt/2 (a + a').
!> One evaluation of B and one M^{-1} application per step; with lumped mass M^{-1} is a
!> diagonal scaling, so a step costs one SpMV with K_theta plus the contact terms.
!>
!> Stability: for the linearized system the scheme is stable iff dt < 2 / omega_max,
!> omega_max^2 the largest eigenvalue of M^{-1} (K_theta + D), D the contact tangent.
!> The run estimates omega_max^2 at full contact (every contact quadrature point active,
!> the stiffest state the contact can reach) by power iteration (critical_step.f90);
!> with `&scheme dt = 0` it runs at SAFETY times the estimate. Power iteration
!> approaches omega_max^2 from below, so the estimate of dt_crit is from above: SAFETY
!> covers that and the nonlinearity.
!>
!> In flight (no active point, L = 0) the scheme conserves the modified energy
!>     1/2 v.M v + 1/2 u.K_theta u - dt^2/8 a.M a
!> exactly (the quadratic invariant of its amplification matrix).
module central_difference
    use kinds, only: dp, i8
    use linear_solver, only: ls_factor_info
    use errors, only: STAT_OK
    use model, only: model_t, model_stiff_apply, model_mass_apply
    use nitsche_contact, only: contact_eval
    use mass_solver, only: mass_solver_t, mass_solver_start, mass_solver_apply, mass_solver_free, &
                           mass_solver_name, mass_solver_kernel
    use time_scheme, only: time_scheme_t, state_t, scheme_params_t, step_solve_failed
    use critical_step, only: critical_dt, CRITICAL_SAFETY
    implicit none
    private

    !> Central differences.
    type, extends(time_scheme_t), public :: central_scheme_t
        real(dp) :: dt_crit = 0.0_dp              !! estimated critical step 2 / omega_max
        type(mass_solver_t) :: ms                 !! M^{-1}
        real(dp), allocatable :: rhs(:)           !! (n) work vector
    contains
        procedure :: init => central_init
        procedure :: step => central_step
        procedure :: free => central_free
        procedure :: solver => central_solver
        procedure :: kernel => central_kernel
        procedure :: factor_info => central_factor_info
    end type central_scheme_t


contains

    !> M factorization (consistent mass), a0 = M^{-1}(L - B(u0)), the critical step
    !> estimate, and dt: when prm%dt is 0, the largest step <= SAFETY dt_crit that
    !> divides prm%t_end (the run ends at t_end, not a fraction of a step after it).
    subroutine central_init(this, mdl, prm, st, stat, errmsg)
        class(central_scheme_t), intent(inout) :: this      !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(scheme_params_t), intent(in) :: prm            !! parameters (dt)
        type(state_t), intent(inout) :: st                  !! initial state
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: n
        real(dp) :: steps
        n = mdl%n_dofs
        allocate (this%rhs(n))
        call mass_solver_start(this%ms, mdl, st%bu, st%a, this%factorizations, stat, errmsg)
        if (stat /= STAT_OK) return
        ! dt_crit = 2 / omega_max at full contact
        call critical_dt(mdl, this%ms, 2.0_dp, 'central', this%dt_crit, stat, errmsg)
        if (stat /= STAT_OK) return
        this%dt = prm%dt
        if (prm%dt == 0.0_dp) then
            this%dt = CRITICAL_SAFETY * this%dt_crit
            if (this%dt > 0.0_dp .and. prm%t_end > 0.0_dp) then
                steps = prm%t_end / this%dt
                if (steps < 1.0e15_dp) this%dt = prm%t_end / real(ceiling(steps, i8), dp)
            end if
        end if
    end subroutine central_init

    !> Release the factors of M.
    subroutine central_free(this)
        class(central_scheme_t), intent(inout) :: this      !! scheme
        call mass_solver_free(this%ms)
    end subroutine central_free

    !> The backend of the M^{-1} applications.
    pure function central_solver(this) result(name)
        class(central_scheme_t), intent(in) :: this      !! scheme
        character(len=:), allocatable :: name
        name = mass_solver_name(this%ms)
    end function central_solver

    !> The triangular solve of the M^{-1} applications.
    pure function central_kernel(this) result(name)
        class(central_scheme_t), intent(in) :: this   !! scheme
        character(len=:), allocatable :: name
        name = mass_solver_kernel(this%ms)
    end function central_kernel

    !> The ordering and the stored entries of the M factors ('' and 0 when lumped).
    pure subroutine central_factor_info(this, ordering, nnz)
        class(central_scheme_t), intent(in) :: this              !! scheme
        character(len=:), allocatable, intent(out) :: ordering  !! ordering's name
        integer(i8), intent(out) :: nnz                         !! stored entries
        call ls_factor_info(this%ms%lu, ordering, nnz)
    end subroutine central_factor_info

    !> One step: u' from (u, v, a), B(u') and M v' products, a' = M^{-1}(L - B(u')).
    subroutine central_step(this, mdl, st, stat, errmsg)
        class(central_scheme_t), intent(inout) :: this      !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(state_t), intent(inout) :: st                  !! state
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: dt, h2
        integer :: i
        dt = this%dt
        h2 = 0.5_dp * dt * dt
        do i = 1, size(st%u)
            st%u(i) = st%u(i) + dt * st%v(i) + h2 * st%a(i)
            st%v(i) = st%v(i) + 0.5_dp * dt * st%a(i)      ! the half of v' known now
        end do
        call model_stiff_apply(mdl, st%u, st%ktu)
        st%bu = st%ktu
        st%active = 0; st%e_pen = 0.0_dp; st%e_theta = 0.0_dp; st%f_n = 0.0_dp
        if (mdl%has_contact) call contact_eval(mdl%ct, st%u, st%bu, st%active, st%e_pen, &
                                               st%e_theta, f_n=st%f_n)
        if (this%ms%lumped) then     ! (set from mdl%lumped: mdl%mass_diag is there)
            ! a' = M^{-1}(L - B(u')), v', M v' in one pass (the same operations as below)
            call lumped_tail(this%ms%inv_diag, mdl%mass_diag, mdl%load, st%bu, dt, st%a, st%v, &
                             st%mv)
            stat = STAT_OK
        else
            this%rhs = mdl%load - st%bu
            call mass_solver_apply(this%ms, this%rhs, st%a, stat, errmsg)
            if (stat /= STAT_OK) then
                call step_solve_failed(this, .false., 'linear solve failed for the mass '// &
                                       'matrix', st%t + dt, stat, errmsg)
                return
            end if
            st%v = st%v + 0.5_dp * dt * st%a
            call model_mass_apply(mdl, st%v, st%mv)      ! M v', formed from v'
        end if
        st%newton_its = 0
        st%t = st%t + dt
    end subroutine central_step

    !> The end of a step with lumped mass in one pass: a' = M^{-1}(L - B(u')) with the
    !> diagonal's inverse, v' = v + dt/2 a' (v holds v + dt/2 a), M v' (the operations of
    !> mass_solver_apply and model_mass_apply, bit for bit).
    pure subroutine lumped_tail(inv_diag, mass_diag, load, bu, dt, a, v, mv)
        real(dp), intent(in) :: inv_diag(:)                 !! 1 / diag(M)
        real(dp), intent(in) :: mass_diag(:)                !! diag(M)
        real(dp), intent(in) :: load(:), bu(:)              !! L, B(u')
        real(dp), intent(in) :: dt                          !! time step
        real(dp), intent(out) :: a(:)                       !! a'
        real(dp), intent(inout) :: v(:)                     !! v + dt/2 a in, v' out
        real(dp), intent(out) :: mv(:)                      !! M v'
        integer :: i
        do i = 1, size(a)
            a(i) = inv_diag(i) * (load(i) - bu(i))
            v(i) = v(i) + 0.5_dp * dt * a(i)
            mv(i) = mass_diag(i) * v(i)
        end do
    end subroutine lumped_tail
end module central_difference
