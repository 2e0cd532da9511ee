!> Predictor-corrector schemes pc (seed eq. 10), pc_hht (eq. 11, standard alpha)
!> and pc_hht_seed (eq. 11 with the seed's printed beta, gamma). Explicit in the
!> contact: no Newton, M factorized once (consistent) or no solve at all (lumped).
!>   v~ = v + dt a,  u~ = u + dt v~,  a~ = M^{-1}(L + alpha B(u) - (1+alpha) B(u~)),
!>   v' = v + dt ((1-gamma) a + gamma a~),
!>   u' = u + dt v + dt^2/2 ((1 - 2 beta) a + 2 beta a~),
!>   a' = M^{-1}(L + alpha B(u) - (1+alpha) B(u')).
!> State: u, v, a are vectors; M v' is formed by a product at the end of each step
!> (in the same pass over the node blocks as K_theta u'), never carried by an update.
module explicit_schemes
    use kinds, only: dp
    use errors, only: STAT_OK
    use model, only: model_t, model_eval_b, model_stiff_mass_apply
    use nitsche_contact, only: contact_eval
    use mass_solver, only: mass_solver_t, mass_solver_start, mass_solver_apply, mass_solver_free, &
                           mass_solver_name
    use time_scheme, only: time_scheme_t, state_t, scheme_params_t, SCHEME_PC, SCHEME_PC_HHT
    implicit none
    private

    !> Predictor-corrector family.
    type, extends(time_scheme_t), public :: pc_scheme_t
        real(dp) :: alpha = 0.0_dp                !! HHT alpha (0 for pc)
        real(dp) :: beta = 0.25_dp                !! corrector beta
        real(dp) :: gamma = 0.5_dp                !! corrector gamma
        type(mass_solver_t) :: ms                 !! M^{-1}
        real(dp), allocatable :: vp(:), up(:), ap(:), bp(:), ktp(:), rhs(:), bold(:)
    contains
        procedure :: init => pc_init
        procedure :: step => pc_step
        procedure :: free => pc_free
        procedure :: solver => pc_solver
    end type pc_scheme_t

contains

    !> Coefficients, M factorization and a0 = M^{-1}(L - B(u0)).
    subroutine pc_init(this, mdl, prm, st, stat, errmsg)
        class(pc_scheme_t), intent(inout) :: this           !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(scheme_params_t), intent(in) :: prm            !! parameters (kind: a pc one)
        type(state_t), intent(inout) :: st                  !! initial state
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: n
        n = mdl%n_dofs
        this%dt = prm%dt
        select case (prm%kind)
        case (SCHEME_PC)
            this%alpha = 0.0_dp; this%beta = prm%beta; this%gamma = prm%gamma
        case (SCHEME_PC_HHT)
            this%alpha = prm%alpha
            this%beta = (1.0_dp - prm%alpha)**2 / 4.0_dp; this%gamma = 0.5_dp - prm%alpha
        case default ! SCHEME_PC_HHT_SEED
            this%alpha = prm%alpha
            this%beta = (1.0_dp + prm%alpha)**2 / 4.0_dp; this%gamma = 0.5_dp + prm%alpha
        end select
        allocate (this%vp(n), this%up(n), this%ap(n), this%bp(n), this%ktp(n), this%rhs(n), &
                  this%bold(n))
        call mass_solver_start(this%ms, mdl, st%bu, st%a, this%factorizations, stat, errmsg)
    end subroutine pc_init

    !> Release the factors of M.
    subroutine pc_free(this)
        class(pc_scheme_t), intent(inout) :: this           !! scheme
        call mass_solver_free(this%ms)
    end subroutine pc_free

    !> The backend of the M^{-1} applications.
    function pc_solver(this) result(name)
        class(pc_scheme_t), intent(in) :: this           !! scheme
        character(len=:), allocatable :: name
        name = mass_solver_name(this%ms)
    end function pc_solver

    !> One predictor-corrector step: two B evaluations, two M^{-1} applications.
    subroutine pc_step(this, mdl, st, stat, errmsg)
        class(pc_scheme_t), intent(inout) :: this           !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(state_t), intent(inout) :: st                  !! state
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: dt, e1, e2
        integer :: act
        dt = this%dt
        this%vp = st%v + dt * st%a
        this%up = st%u + dt * this%vp
        call model_eval_b(mdl, this%up, this%bp, this%ktp, act, e1, e2)
        this%rhs = mdl%load + this%alpha * st%bu - (1.0_dp + this%alpha) * this%bp
        call mass_solver_apply(this%ms, this%rhs, this%ap, stat, errmsg)
        if (stat /= STAT_OK) return
        st%u = st%u + dt * st%v + 0.5_dp * dt**2 * ((1.0_dp - 2.0_dp * this%beta) * st%a &
                                                   + 2.0_dp * this%beta * this%ap)
        st%v = st%v + dt * ((1.0_dp - this%gamma) * st%a + this%gamma * this%ap)
        this%bold = st%bu
        ! B(u') = K_theta u' + C(u'), with M v' formed in the same pass
        call model_stiff_mass_apply(mdl, st%u, st%v, st%ktu, st%mv)
        st%bu = st%ktu
        st%active = 0; st%e_pen = 0.0_dp; st%e_theta = 0.0_dp
        if (mdl%has_contact) call contact_eval(mdl%ct, st%u, st%bu, st%active, st%e_pen, &
                                               st%e_theta)
        this%rhs = mdl%load + this%alpha * this%bold - (1.0_dp + this%alpha) * st%bu
        call mass_solver_apply(this%ms, this%rhs, st%a, stat, errmsg)
        st%newton_its = 0
        st%t = st%t + dt
    end subroutine pc_step
end module explicit_schemes
