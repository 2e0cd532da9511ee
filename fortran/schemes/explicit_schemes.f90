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
    use kinds, only: dp, i8
    use linear_solver, only: ls_factor_info
    use errors, only: STAT_OK
    use model, only: model_t, model_stiff_apply, model_stiff_mass_apply
    use nitsche_contact, only: contact_eval
    use mass_solver, only: mass_solver_t, mass_solver_start, mass_solver_apply, mass_solver_free, &
                           mass_solver_name, mass_solver_kernel
    use time_scheme, only: time_scheme_t, state_t, scheme_params_t, SCHEME_PC, SCHEME_PC_HHT, &
                           step_solve_failed
    implicit none
    private

    !> Predictor-corrector family.
    type, extends(time_scheme_t), public :: pc_scheme_t
        real(dp) :: alpha = 0.0_dp                !! HHT alpha (0 for pc)
        real(dp) :: beta = 0.25_dp                !! corrector beta
        real(dp) :: gamma = 0.5_dp                !! corrector gamma
        type(mass_solver_t) :: ms                 !! M^{-1}
        real(dp), allocatable :: up(:), ap(:), bp(:), rhs(:), base(:)  !! (n) work vectors
    contains
        procedure :: init => pc_init
        procedure :: step => pc_step
        procedure :: free => pc_free
        procedure :: solver => pc_solver
        procedure :: kernel => pc_kernel
        procedure :: factor_info => pc_factor_info
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
        allocate (this%up(n), this%ap(n), this%bp(n), this%rhs(n), this%base(n))
        call mass_solver_start(this%ms, mdl, st%bu, st%a, this%factorizations, stat, errmsg)
    end subroutine pc_init

    !> Release the factors of M.
    subroutine pc_free(this)
        class(pc_scheme_t), intent(inout) :: this           !! scheme
        call mass_solver_free(this%ms)
    end subroutine pc_free

    !> The backend of the M^{-1} applications.
    pure function pc_solver(this) result(name)
        class(pc_scheme_t), intent(in) :: this           !! scheme
        character(len=:), allocatable :: name
        name = mass_solver_name(this%ms)
    end function pc_solver

    !> The triangular solve of the M^{-1} applications.
    pure function pc_kernel(this) result(name)
        class(pc_scheme_t), intent(in) :: this        !! scheme
        character(len=:), allocatable :: name
        name = mass_solver_kernel(this%ms)
    end function pc_kernel

    !> The ordering and the stored entries of the M factors ('' and 0 when lumped).
    pure subroutine pc_factor_info(this, ordering, nnz)
        class(pc_scheme_t), intent(in) :: this              !! scheme
        character(len=:), allocatable, intent(out) :: ordering  !! ordering's name
        integer(i8), intent(out) :: nnz                         !! stored entries
        call ls_factor_info(this%ms%lu, ordering, nnz)
    end subroutine pc_factor_info

    !> One predictor-corrector step: two B evaluations, two M^{-1} applications, and
    !> three passes over the vectors besides them (the predictor; the first right-hand
    !> side with the part of the second that is known then, L + alpha B(u); the update).
    subroutine pc_step(this, mdl, st, stat, errmsg)
        class(pc_scheme_t), intent(inout) :: this           !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(state_t), intent(inout) :: st                  !! state
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: dt, e1, e2, c1, c2, g1, g2, al
        integer :: act, i
        dt = this%dt
        al = this%alpha
        ! predictor u^p = u + dt (v + dt a), and B(u^p)
        do i = 1, size(st%u)
            this%up(i) = st%u(i) + dt * (st%v(i) + dt * st%a(i))
        end do
        call model_stiff_apply(mdl, this%up, this%bp)
        act = 0
        if (mdl%has_contact) call contact_eval(mdl%ct, this%up, this%bp, act, e1, e2)
        ! M a^p = L + alpha B(u) - (1 + alpha) B(u^p); base = L + alpha B(u) for the corrector
        do i = 1, size(st%u)
            this%base(i) = mdl%load(i) + al * st%bu(i)
            this%rhs(i) = this%base(i) - (1.0_dp + al) * this%bp(i)
        end do
        call mass_solver_apply(this%ms, this%rhs, this%ap, stat, errmsg)
        if (stat /= STAT_OK) then
            call step_solve_failed(this, .false., 'linear solve failed for the mass matrix', &
                                   st%t + dt, stat, errmsg)
            return
        end if
        ! u' = u + dt v + dt^2/2 ((1 - 2 beta) a + 2 beta a^p), v' = v + dt ((1 - gamma) a
        ! + gamma a^p)
        c1 = 1.0_dp - 2.0_dp * this%beta
        c2 = 2.0_dp * this%beta
        g1 = 1.0_dp - this%gamma
        g2 = this%gamma
        do i = 1, size(st%u)
            st%u(i) = st%u(i) + dt * st%v(i) + 0.5_dp * dt**2 * (c1 * st%a(i) + c2 * this%ap(i))
            st%v(i) = st%v(i) + dt * (g1 * st%a(i) + g2 * this%ap(i))
        end do
        ! B(u') = K_theta u' + C(u'), with M v' formed in the same pass
        call model_stiff_mass_apply(mdl, st%u, st%v, st%ktu, st%mv)
        st%bu = st%ktu
        st%active = 0; st%e_pen = 0.0_dp; st%e_theta = 0.0_dp; st%f_n = 0.0_dp
        if (mdl%has_contact) call contact_eval(mdl%ct, st%u, st%bu, st%active, st%e_pen, &
                                               st%e_theta, f_n=st%f_n)
        ! M a' = L + alpha B(u) - (1 + alpha) B(u')
        do i = 1, size(st%u)
            this%rhs(i) = this%base(i) - (1.0_dp + al) * st%bu(i)
        end do
        call mass_solver_apply(this%ms, this%rhs, st%a, stat, errmsg)
        if (stat /= STAT_OK) then
            call step_solve_failed(this, .false., 'linear solve failed for the mass matrix', &
                                   st%t + dt, stat, errmsg)
            return
        end if
        st%newton_its = 0
        st%t = st%t + dt
    end subroutine pc_step
end module explicit_schemes
