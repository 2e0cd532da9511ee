!> Predictor-corrector schemes pc (seed eq. 10), pc_hht (eq. 11, standard alpha)
!> and pc_hht_seed (eq. 11 with the seed's printed beta, gamma). Explicit in the
!> contact: no Newton, M factorized once (consistent) or no solve at all (lumped).
!>   v~ = v + dt a,  u~ = u + dt v~,  a~ = M^{-1}(L + alpha B(u) - (1+alpha) B(u~)),
!>   v' = v + dt ((1-gamma) a + gamma a~),
!>   u' = u + dt v + dt^2/2 ((1 - 2 beta) a + 2 beta a~),
!>   a' = M^{-1}(L + alpha B(u) - (1+alpha) B(u')).
!> State: u, v, a are vectors; M v' is formed by a product at the end of each step
!> (in the same pass over the node blocks as K_theta u'), never carried by an update.
!>
!> Stability. On one mode M u'' = -omega^2 M u in flight (L = 0, B(u) = omega^2 M u) the
!> step is linear in (U, V, A) = (u, dt v, dt^2 a): (U, V, A)' = P(Omega) (U, V, A), Omega
!> = omega dt, P the amplification matrix (pc_amplification, built by applying the
!> equations above to the unit vectors). a' depends on u and u' (alpha B(u)), so P is
!> 3 x 3; for alpha = 0, A = -Omega^2 U and P reduces to the 2 x 2 matrix of (U, V). The
!> step is stable at Omega while every root of det(z - P(Omega)) is in the closed unit
!> disc; Omega_c (pc_stability_limit) is the first Omega > 0 where one leaves it, and
!> the run's critical step is dt_crit = Omega_c / omega_max (critical_step.f90). In
!> closed form: pc (beta, gamma) = (1/4, 1/2), sqrt(2); pc_hht, alpha in [-1/3, 0], the
!> root z = 1 crossing, 2 / sqrt(2 - 2 alpha - 3 alpha^2 + alpha^3); pc_hht_seed with
!> alpha < 0 (gamma < 1/2), 0: the pair of roots near z = 1 has the product
!> 1 + (1/2 - gamma - alpha) Omega^2 + O(Omega^4), above 1 for every small Omega
!> (docs/numerics.md, "Explicit schemes").
module explicit_schemes
    use kinds, only: dp, i8
    use linear_solver, only: ls_factor_info
    use errors, only: STAT_OK
    use critical_step, only: critical_dt
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
        real(dp) :: omega_c = 0.0_dp              !! stability limit of omega dt (one mode)
        real(dp) :: dt_crit = 0.0_dp              !! estimated critical step omega_c / omega_max
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

    public :: pc_amplification, pc_stability_limit

contains

    !> Coefficients, M factorization, a0 = M^{-1}(L - B(u0)), and the critical step
    !> estimate omega_c / omega_max (0 when omega_c is: no step is stable).
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
        if (stat /= STAT_OK) return
        this%omega_c = pc_stability_limit(this%alpha, this%beta, this%gamma)
        call critical_dt(mdl, this%ms, this%omega_c, 'pc', this%dt_crit, stat, errmsg)
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

    !> The amplification matrix P of one step on one mode in flight, (U, V, A)' =
    !> P (U, V, A) with (U, V, A) = (u, dt v, dt^2 a) (module header): column j is the
    !> step's equations applied to the j-th unit vector, with B(u) = omega^2 u, L = 0.
    pure function pc_amplification(alpha, beta, gamma, omega_dt) result(p)
        real(dp), intent(in) :: alpha                       !! HHT alpha (0 for pc)
        real(dp), intent(in) :: beta, gamma                 !! corrector beta, gamma
        real(dp), intent(in) :: omega_dt                    !! Omega = omega dt >= 0
        real(dp) :: p(3, 3)
        real(dp) :: w, e(3), ut, at
        integer :: j
        w = omega_dt**2
        do j = 1, 3
            e = 0.0_dp
            e(j) = 1.0_dp
            ut = e(1) + e(2) + e(3)                              ! u~ = u + dt v + dt^2 a
            at = alpha * w * e(1) - (1.0_dp + alpha) * w * ut    ! a~
            p(1, j) = e(1) + e(2) + 0.5_dp * ((1.0_dp - 2.0_dp * beta) * e(3) + 2.0_dp * beta * at)
            p(2, j) = e(2) + (1.0_dp - gamma) * e(3) + gamma * at
            p(3, j) = alpha * w * e(1) - (1.0_dp + alpha) * w * p(1, j)
        end do
    end function pc_amplification

    !> Whether every root of det(z - P) is in the closed unit disc, P = pc_amplification
    !> at omega_dt: the Schur-Cohn-Jury conditions on z^3 + c2 z^2 + c1 z + c0 (c2 =
    !> -trace P, c1 the sum of the principal 2 x 2 minors, c0 = -det P), no eigenvalues:
    !> p(1) >= 0, -p(-1) >= 0, 1 - |c0| >= 0, 1 - c0^2 - |c1 - c0 c2| >= 0, each to within
    !> the rounding of its evaluation. That bound is the matrix's: each condition is a sum
    !> of products of at most six entries of P, formed in at most 16 rounded operations
    !> from them, so its error is at most 16 eps times the same sum taken in absolute
    !> values (the running error bound of a polynomial evaluation), the tolerance used.
    !> The boundary points themselves (a root at 1, the double root 1 at Omega = 0) thus
    !> count as stable, as they are: the bisection of pc_stability_limit needs no tuned
    !> margin.
    pure logical function pc_stable(alpha, beta, gamma, omega_dt) result(ok)
        real(dp), intent(in) :: alpha                       !! HHT alpha (0 for pc)
        real(dp), intent(in) :: beta, gamma                 !! corrector beta, gamma
        real(dp), intent(in) :: omega_dt                    !! Omega = omega dt
        real(dp), parameter :: ops = 16.0_dp * epsilon(1.0_dp)
        real(dp) :: p(3, 3), q(3, 3), c0, c1, c2, m0, m1, m2, cond(4), mag(4)
        p = pc_amplification(alpha, beta, gamma, omega_dt)
        q = abs(p)
        c2 = -(p(1, 1) + p(2, 2) + p(3, 3))
        m2 = q(1, 1) + q(2, 2) + q(3, 3)
        c1 = p(1, 1) * p(2, 2) - p(1, 2) * p(2, 1) + p(1, 1) * p(3, 3) - p(1, 3) * p(3, 1) &
             + p(2, 2) * p(3, 3) - p(2, 3) * p(3, 2)
        m1 = q(1, 1) * q(2, 2) + q(1, 2) * q(2, 1) + q(1, 1) * q(3, 3) + q(1, 3) * q(3, 1) &
             + q(2, 2) * q(3, 3) + q(2, 3) * q(3, 2)
        c0 = -(p(1, 1) * (p(2, 2) * p(3, 3) - p(2, 3) * p(3, 2)) &
               - p(1, 2) * (p(2, 1) * p(3, 3) - p(2, 3) * p(3, 1)) &
               + p(1, 3) * (p(2, 1) * p(3, 2) - p(2, 2) * p(3, 1)))
        m0 = q(1, 1) * (q(2, 2) * q(3, 3) + q(2, 3) * q(3, 2)) &
             + q(1, 2) * (q(2, 1) * q(3, 3) + q(2, 3) * q(3, 1)) &
             + q(1, 3) * (q(2, 1) * q(3, 2) + q(2, 2) * q(3, 1))
        cond = [1.0_dp + c2 + c1 + c0, 1.0_dp - c2 + c1 - c0, 1.0_dp - abs(c0), &
                1.0_dp - c0**2 - abs(c1 - c0 * c2)]
        mag = [1.0_dp + m2 + m1 + m0, 1.0_dp + m2 + m1 + m0, 1.0_dp + m0, &
               1.0_dp + m0**2 + m1 + m0 * m2]
        ok = all(cond >= -ops * mag)
    end function pc_stable

    !> Omega_c, the stability limit of omega dt of the pc family with these coefficients
    !> (module header): 0 when the pair of roots near z = 1 leaves the unit disc at first
    !> order in Omega^2 (1/2 - gamma - alpha > 0 beyond its rounding: no step is
    !> stable); else the first
    !> unstable point of a scan of 64 points up to the first unstable power of 2, then
    !> bisection to the last bit. The scan finds the first exit from the disc as long as
    !> the stable Omega do not come back within a 64th of the scan's range.
    pure function pc_stability_limit(alpha, beta, gamma) result(omega_c)
        real(dp), intent(in) :: alpha                       !! HHT alpha (0 for pc)
        real(dp), intent(in) :: beta, gamma                 !! corrector beta, gamma
        real(dp) :: omega_c
        integer, parameter :: SCAN = 64, MAX_DOUBLINGS = 60
        real(dp) :: lo, hi, mid, top
        integer :: k
        omega_c = 0.0_dp
        ! 0 exactly for pc_hht (gamma = 1/2 - alpha), computed to within 2 roundings
        if (0.5_dp - gamma - alpha > 4.0_dp * epsilon(1.0_dp) * (0.5_dp + abs(gamma) + &
                                                                abs(alpha))) return
        top = 1.0_dp
        do k = 1, MAX_DOUBLINGS      ! an explicit step is unstable at a large enough Omega
            if (.not. pc_stable(alpha, beta, gamma, top)) exit
            top = 2.0_dp * top
        end do
        if (pc_stable(alpha, beta, gamma, top)) then
            omega_c = top; return    ! (not reached: at least this)
        end if
        lo = 0.0_dp
        hi = top
        do k = 1, SCAN
            hi = top * real(k, dp) / real(SCAN, dp)
            if (.not. pc_stable(alpha, beta, gamma, hi)) exit
            lo = hi
        end do
        do
            mid = 0.5_dp * (lo + hi)
            if (mid <= lo .or. mid >= hi) exit
            if (pc_stable(alpha, beta, gamma, mid)) then
                lo = mid
            else
                hi = mid
            end if
        end do
        omega_c = lo
    end function pc_stability_limit
end module explicit_schemes
