!> Implicit schemes newmark, hht, hht_seed and theta over one semi-smooth Newton
!> driver. Every step solves
!>     R(x) = M (x - u~) + c B(x) - b = 0,   J = M + c B'(x),
!> with u~, c, b set by the scheme:
!>   Newmark family (newmark, hht, hht_seed, galpha), in generalized-alpha form:
!>     (1-am) M a' + am M a + (1-af) B(u') + af B(u) = L, u' = u~ + beta dt^2 a',
!>     u~ = u + dt v + dt^2 (1/2 - beta) a, v' = v + dt ((1-gamma) a + gamma a');
!>     newmark: am = af = 0; hht/hht_seed (alpha <= 0): am = 0, af = -alpha;
!>     galpha (Chung-Hulbert 1993, rho_inf in [0, 1]): am = (2 rho - 1)/(rho + 1),
!>     af = rho/(rho + 1), beta = (1 - am + af)^2/4, gamma = 1/2 - am + af.
!>     Multiplied by beta dt^2/(1-am): c = beta dt^2 (1-af)/(1-am),
!>     b = beta dt^2/(1-am) (L - af B(u)), and M (u - u~) becomes M (u - u~ + k a) with
!>     k = beta dt^2 am/(1-am) (k = 0 and the same operations as plain HHT when am = 0).
!>   theta: u' = u + dt (theta v' + (1-theta) v), M (v' - v) = dt (L - theta B(u')
!>     - (1-theta) B(u)), so u~ = u + dt v, c = theta^2 dt^2,
!>     b = theta dt^2 (L - (1-theta) B(u)).
!> State: u, v, a are the only copies of the truth. The predictor u~ is formed as a
!> vector and M (u^n - u~) by a product with M (as GetFEM does); a' = (x - u~) /
!> (beta dt^2) and v' are formed from vectors; M v' is a product formed at the end of
!> the step, in the same pass over the node blocks as K_theta u' and the next step's
!> M (u' - u~'). No product is carried across steps by an update identity, so none
!> can drift from the vector it stands for.
!> J = J0 + c P^T U V^T P where J0 = M + c K_theta is factorized once and
!> D = U V^T (one rank-one term per active contact quadrature point, on the dofs of
!> the contact cells) is the contact tangent: J^{-1} is applied with the Woodbury
!> identity (Z = J0^{-1} P^T precomputed), so the active set changing never costs a
!> factorization, and the correction costs O(n m + m r + r^3).
module implicit_schemes
    use kinds, only: dp
    use text, only: int_text, real_text
    use errors, only: STAT_OK, STAT_NUMERIC, raise
    use sparse, only: csc_t
    use linear_solver, only: factor_t, ls_factor, ls_solve, ls_solve_many, ls_free
    use dense_lu, only: dense_lu_factor, dense_lu_solve
    use model, only: model_t, model_eval_b, model_mass_apply, model_step_products
    use nitsche_contact, only: contact_eval, contact_max_rank
    use mass_solver, only: mass_solver_t, mass_solver_start, mass_solver_free
    use time_scheme, only: time_scheme_t, state_t, scheme_params_t, SCHEME_NEWMARK, SCHEME_HHT, &
                           SCHEME_HHT_SEED, SCHEME_GALPHA
    implicit none
    private

    integer, parameter :: KIND_NEWMARK = 1   ! newmark, hht, hht_seed
    integer, parameter :: KIND_THETA = 2     ! theta

    !> Newmark-family and theta schemes.
    type, extends(time_scheme_t), public :: implicit_scheme_t
        integer :: kind = KIND_NEWMARK            !! family
        real(dp) :: alpha_m = 0.0_dp              !! generalized-alpha alpha_m (0 but for galpha)
        real(dp) :: alpha_f = 0.0_dp              !! alpha_f (-alpha for hht, hht_seed)
        real(dp) :: beta = 0.25_dp                !! Newmark beta
        real(dp) :: gamma = 0.5_dp                !! Newmark gamma
        real(dp) :: theta = 0.5_dp                !! theta-scheme theta
        real(dp) :: c = 0.0_dp                    !! coefficient of B in R
        real(dp) :: tol = 1.0e-10_dp              !! relative residual tolerance
        integer :: maxit = 50                     !! Newton iteration limit
        type(csc_t) :: jac0                       !! J0 = M + c K_theta
        type(factor_t) :: lu0                     !! its factors
        integer :: m = 0                          !! contact-cell dofs
        real(dp), allocatable :: z(:, :)          !! (n, m) J0^{-1} P^T
        real(dp), allocatable :: w(:, :)          !! (m, m) P J0^{-1} P^T
        integer :: rank = 0                       !! rank of the contact tangent D = U V^T
        real(dp), allocatable :: ua(:, :)         !! (ndof_e, rmax) columns of U (on qloc)
        real(dp), allocatable :: vb(:, :)         !! (ndof_e, rmax) columns of V (on qloc)
        integer, allocatable :: qloc(:, :)        !! (ndof_e, rmax) their contact-cell dofs
        real(dp), allocatable :: wu(:, :)         !! (m, rmax) W U
        real(dp), allocatable :: small(:, :)      !! (rmax, rmax) Woodbury system I + c V^T W U
        real(dp), allocatable :: zs(:)            !! (rmax) its right-hand side / solution
        integer, allocatable :: piv(:)            !! (rmax) pivots
        real(dp), allocatable :: tvec(:)          !! (m) U z, the correction's coefficients
        real(dp), allocatable :: cx(:), cold(:)   !! (m) contact part of B at the iterate, previous
        real(dp), allocatable :: ut(:)            !! (n) predictor u~ of the next step
        real(dp), allocatable :: md(:)            !! (n) M (u - u~), formed with ut
        real(dp), allocatable :: dvec(:)          !! (n) u - u~ (the vector multiplied by M)
        real(dp), allocatable :: b(:), r(:), dx(:), x(:), scratch(:)  !! (n) work vectors
    contains
        procedure :: init => implicit_init
        procedure :: step => implicit_step
        procedure :: free => implicit_free
        procedure :: solver => implicit_solver
    end type implicit_scheme_t

contains

    !> Coefficients from the parameters, J0 factorization, Woodbury blocks, and the
    !> initial acceleration M a0 = L - B(u0) for the Newmark family.
    subroutine implicit_init(this, mdl, prm, st, stat, errmsg)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(scheme_params_t), intent(in) :: prm            !! parameters (kind: an implicit one)
        type(state_t), intent(inout) :: st                  !! initial state
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        type(mass_solver_t) :: ms
        integer :: n, j, rmax
        real(dp), allocatable :: e(:, :)
        n = mdl%n_dofs
        this%dt = prm%dt
        this%tol = prm%newton_tol
        this%maxit = prm%newton_maxit
        select case (prm%kind)
        case (SCHEME_NEWMARK)
            this%kind = KIND_NEWMARK
            this%beta = prm%beta; this%gamma = prm%gamma
        case (SCHEME_HHT)
            this%kind = KIND_NEWMARK; this%alpha_f = -prm%alpha
            this%beta = (1.0_dp - prm%alpha)**2 / 4.0_dp; this%gamma = 0.5_dp - prm%alpha
        case (SCHEME_HHT_SEED)
            this%kind = KIND_NEWMARK; this%alpha_f = -prm%alpha
            this%beta = (1.0_dp + prm%alpha)**2 / 4.0_dp; this%gamma = 0.5_dp + prm%alpha
        case (SCHEME_GALPHA)
            this%kind = KIND_NEWMARK
            this%alpha_m = (2.0_dp * prm%rho_inf - 1.0_dp) / (prm%rho_inf + 1.0_dp)
            this%alpha_f = prm%rho_inf / (prm%rho_inf + 1.0_dp)
            this%beta = (1.0_dp - this%alpha_m + this%alpha_f)**2 / 4.0_dp
            this%gamma = 0.5_dp - this%alpha_m + this%alpha_f
        case default    ! SCHEME_THETA
            this%kind = KIND_THETA; this%theta = prm%theta
        end select
        if (this%kind == KIND_NEWMARK) then
            this%c = this%beta * this%dt**2 * (1.0_dp - this%alpha_f) / (1.0_dp - this%alpha_m)
        else
            this%c = (this%theta * this%dt)**2
        end if
        allocate (this%ut(n), this%md(n), this%dvec(n), this%b(n), this%r(n), this%dx(n), &
                  this%x(n), this%scratch(n))

        ! initial acceleration (Newmark family only)
        if (this%kind == KIND_NEWMARK) then
            call mass_solver_start(ms, mdl, st%bu, st%a, this%factorizations, stat, errmsg)
            call mass_solver_free(ms)
            if (stat /= STAT_OK) return
        else
            st%a = 0.0_dp
        end if
        ! the first step's predictor u~ and M (u0 - u~)
        call form_predictor(this, st%u, st%v, st%a)
        call model_mass_apply(mdl, this%dvec, this%md)

        this%jac0 = mdl%mass
        this%jac0%val = mdl%mass%val + this%c * mdl%stiff_theta%val
        call ls_factor(this%lu0, this%jac0, stat, errmsg)
        if (stat /= STAT_OK) return
        this%factorizations = this%factorizations + 1

        this%m = 0
        if (mdl%has_contact) this%m = mdl%ct%m
        rmax = 0
        if (mdl%has_contact) rmax = contact_max_rank(mdl%ct)
        allocate (this%z(n, this%m), this%w(this%m, this%m), this%ua(mdl%ndof_e, rmax), &
                  this%vb(mdl%ndof_e, rmax), this%qloc(mdl%ndof_e, rmax), this%wu(this%m, rmax), &
                  this%small(rmax, rmax), this%zs(rmax), this%piv(rmax), this%tvec(this%m), &
                  this%cx(this%m), this%cold(this%m), e(n, this%m))
        this%scratch = 0.0_dp
        ! Z = J0^{-1} P^T: one solve per contact-cell dof
        e = 0.0_dp
        do j = 1, this%m
            e(mdl%ct%cdofs(j), j) = 1.0_dp
        end do
        call ls_solve_many(this%lu0, this%jac0, e, this%z, stat, errmsg)
        if (stat /= STAT_OK) return
        if (this%m > 0) this%w = this%z(mdl%ct%cdofs, :)
    end subroutine implicit_init

    !> Release the factors of J0.
    subroutine implicit_free(this)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        call ls_free(this%lu0)
    end subroutine implicit_free

    !> The backend of the J0 factors.
    function implicit_solver(this) result(name)
        class(implicit_scheme_t), intent(in) :: this        !! scheme
        character(len=:), allocatable :: name
        name = trim(this%lu0%backend)
    end function implicit_solver

    !> One step: semi-smooth Newton from x = u^n. u~ and M (u^n - u~) were formed at
    !> the end of the previous step (or in init); after each solve J dx = -R the
    !> residual is updated exactly from the solve identity, R' = c (C(x') - C(x) - D dx)
    !> (C = contact part of B, D its tangent), so a contact-free step costs one solve
    !> and one pass over the matrix blocks (K_theta u', M v', M (u' - u~')).
    subroutine implicit_step(this, mdl, st, stat, errmsg)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(state_t), intent(inout) :: st                  !! state
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: dt, rnorm, scale, e_pen, e_theta, acc
        real(dp) :: s_mx, s_bu, s_b, s_r, cb, ai, inv, g1, g2
        integer :: it, active, i, q
        stat = STAT_OK
        dt = this%dt
        ! right-hand side b and R(u^n) = M (u^n - u~) + c B(u^n) - b in one pass, with the
        ! sums of squares of the convergence test
        s_mx = 0.0_dp; s_bu = 0.0_dp; s_b = 0.0_dp; s_r = 0.0_dp
        if (this%kind == KIND_NEWMARK) then
            cb = this%beta * dt**2 / (1.0_dp - this%alpha_m)
            do i = 1, size(st%u)
                this%b(i) = cb * (mdl%load(i) - this%alpha_f * st%bu(i))
                this%r(i) = this%md(i) + this%c * st%bu(i) - this%b(i)
                s_mx = s_mx + this%md(i)**2; s_bu = s_bu + st%bu(i)**2
                s_b = s_b + this%b(i)**2; s_r = s_r + this%r(i)**2
            end do
        else
            cb = this%theta * dt**2
            do i = 1, size(st%u)
                this%b(i) = cb * (mdl%load(i) - (1.0_dp - this%theta) * st%bu(i))
                this%r(i) = this%md(i) + this%c * st%bu(i) - this%b(i)
                s_mx = s_mx + this%md(i)**2; s_bu = s_bu + st%bu(i)**2
                s_b = s_b + this%b(i)**2; s_r = s_r + this%r(i)**2
            end do
        end if
        scale = sqrt(s_mx) + this%c * sqrt(s_bu) + sqrt(s_b)
        rnorm = sqrt(s_r)
        this%x = st%u
        active = st%active; e_pen = st%e_pen; e_theta = st%e_theta
        if (this%m > 0) call contact_part(this%x, this%cx, active, e_pen, e_theta)
        it = 0
        do
            if (rnorm <= this%tol * scale) exit
            if (.not. (rnorm == rnorm) .or. it >= this%maxit) then
                call raise(stat, errmsg, STAT_NUMERIC, 'Newton did not converge at t = ' &
                           //real_text(st%t + dt, 6)//' after '//int_text(it) &
                           //' iterations (relative residual ' &
                           //real_text(rnorm / max(scale, tiny(1.0_dp)), 4)//')')
                st%newton_its = it
                this%newton_total = this%newton_total + it
                return
            end if
            ! dx = J^{-1} R, the Newton step is x <- x - dx
            call solve_jacobian(this%r, this%dx, stat)
            if (stat /= STAT_OK) then
                call raise(stat, errmsg, STAT_NUMERIC, 'linear solve failed in Newton at t = ' &
                           //real_text(st%t + dt, 6))
                return
            end if
            this%x = this%x - this%dx
            it = it + 1
            ! after a solve R is zero but on the contact-cell dofs
            if (it == 1) this%r = 0.0_dp
            rnorm = 0.0_dp
            if (this%m == 0) exit
            ! R' = c (C(x') - C(x) - D (x' - x)) = c (C(x') - C(x) + D dx) on the
            ! contact-cell dofs; tvec = D dx, D = U V^T at the previous iterate
            this%tvec = 0.0_dp
            do q = 1, this%rank
                acc = 0.0_dp
                do i = 1, mdl%ndof_e
                    if (this%qloc(i, q) > 0) acc = acc + this%vb(i, q) &
                                                   * this%dx(mdl%ct%cdofs(this%qloc(i, q)))
                end do
                do i = 1, mdl%ndof_e
                    if (this%qloc(i, q) > 0) this%tvec(this%qloc(i, q)) = &
                        this%tvec(this%qloc(i, q)) + this%ua(i, q) * acc
                end do
            end do
            this%cold = this%cx
            call contact_part(this%x, this%cx, active, e_pen, e_theta)
            s_r = 0.0_dp
            do i = 1, this%m
                this%r(mdl%ct%cdofs(i)) = this%c * (this%cx(i) - this%cold(i) + this%tvec(i))
                s_r = s_r + this%r(mdl%ct%cdofs(i))**2
            end do
            rnorm = sqrt(s_r)
        end do
        st%newton_its = it
        this%newton_total = this%newton_total + it
        ! the scheme's update of u, v, a from vectors, then the next predictor u~', and
        ! K_theta u', M v', M (u' - u~') in one pass; B(u') = K_theta u' + C(u').
        ! Dofs without inertia (redistributed mass) are quasi-static: their v, a do not
        ! enter the dynamics (zero rows of M), and are reported as v = (u' - u)/dt, a = 0.
        do q = 1, size(mdl%massless_dofs)
            i = mdl%massless_dofs(q)
            this%dvec(i) = (this%x(i) - st%u(i)) / dt
        end do
        if (this%kind == KIND_NEWMARK) then
            ! a' = (x - u~) / (beta dt^2); v' = v + dt ((1-gamma) a + gamma a')
            inv = 1.0_dp / (this%beta * dt**2)
            g1 = dt * (1.0_dp - this%gamma)
            g2 = dt * this%gamma
            do i = 1, size(st%u)
                ai = (this%x(i) - this%ut(i)) * inv
                st%v(i) = st%v(i) + g1 * st%a(i) + g2 * ai
                st%a(i) = ai
                st%u(i) = this%x(i)
            end do
        else
            ! v' = (x - u - dt (1-theta) v) / (theta dt)
            inv = 1.0_dp / (this%theta * dt)
            g1 = dt * (1.0_dp - this%theta)
            do i = 1, size(st%u)
                st%v(i) = (this%x(i) - st%u(i) - g1 * st%v(i)) * inv
                st%u(i) = this%x(i)
            end do
        end if
        do q = 1, size(mdl%massless_dofs)
            i = mdl%massless_dofs(q)
            st%v(i) = this%dvec(i)
            if (this%kind == KIND_NEWMARK) st%a(i) = 0.0_dp
        end do
        call form_predictor(this, st%u, st%v, st%a)
        call model_step_products(mdl, st%u, st%v, this%dvec, st%ktu, st%mv, this%md)
        st%bu = st%ktu
        if (this%m > 0) st%bu(mdl%ct%cdofs) = st%bu(mdl%ct%cdofs) + this%cx
        st%active = active; st%e_pen = e_pen; st%e_theta = e_theta
        st%t = st%t + dt

    contains

        !> Contact part C(xx) of B on the contact-cell dofs, its tangent in low-rank
        !> form (rank, ua, vb, qloc) and the contact energy parts.
        subroutine contact_part(xx, cvec, act, ep, et)
            real(dp), intent(in) :: xx(:)
            real(dp), intent(out) :: cvec(:)
            integer, intent(out) :: act
            real(dp), intent(out) :: ep, et
            this%scratch(mdl%ct%cdofs) = 0.0_dp
            call contact_eval(mdl%ct, xx, this%scratch, act, ep, et, this%rank, this%ua, this%vb, &
                              this%qloc)
            cvec = this%scratch(mdl%ct%cdofs)
        end subroutine contact_part

        !> y = J^{-1} rhs with J = J0 + c P^T U V^T P (Woodbury, rank r):
        !> y = y0 - Z U (I + c V^T W U)^{-1} c V^T P y0, y0 = J0^{-1} rhs.
        subroutine solve_jacobian(rhs, y, st2)
            real(dp), intent(in) :: rhs(:)
            real(dp), intent(out) :: y(:)
            integer, intent(out) :: st2
            integer :: r, i, j, k, info, l
            real(dp) :: acc2
            call ls_solve(this%lu0, this%jac0, rhs, y, st2)
            r = this%rank
            if (st2 /= STAT_OK .or. this%m == 0 .or. r == 0) return
            ! W U: each column of U lives on <= ndof_e contact-cell dofs
            do j = 1, r
                this%wu(:, j) = 0.0_dp
                do k = 1, mdl%ndof_e
                    l = this%qloc(k, j)
                    if (l > 0) this%wu(:, j) = this%wu(:, j) + this%ua(k, j) * this%w(:, l)
                end do
            end do
            ! small = I + c V^T W U; zs = c V^T y_c
            do i = 1, r
                do j = 1, r
                    acc2 = 0.0_dp
                    do k = 1, mdl%ndof_e
                        l = this%qloc(k, i)
                        if (l > 0) acc2 = acc2 + this%vb(k, i) * this%wu(l, j)
                    end do
                    this%small(i, j) = this%c * acc2
                end do
                this%small(i, i) = this%small(i, i) + 1.0_dp
                acc2 = 0.0_dp
                do k = 1, mdl%ndof_e
                    l = this%qloc(k, i)
                    if (l > 0) acc2 = acc2 + this%vb(k, i) * y(mdl%ct%cdofs(l))
                end do
                this%zs(i) = this%c * acc2
            end do
            call dense_lu_factor(r, this%small, this%piv, info)
            if (info /= 0) then
                st2 = STAT_NUMERIC
                return
            end if
            call dense_lu_solve(r, this%small, this%piv, this%zs)
            ! y = y - Z (U z)
            this%tvec = 0.0_dp
            do j = 1, r
                do k = 1, mdl%ndof_e
                    l = this%qloc(k, j)
                    if (l > 0) this%tvec(l) = this%tvec(l) + this%ua(k, j) * this%zs(j)
                end do
            end do
            do l = 1, this%m
                if (this%tvec(l) /= 0.0_dp) y = y - this%tvec(l) * this%z(:, l)
            end do
        end subroutine solve_jacobian
    end subroutine implicit_step


    !> The predictor of the step that starts from (u, v, a): u~ = u + dt v + dt^2 (1/2 -
    !> beta) a (Newmark family) or u + dt v (theta), formed as a vector, and dvec = u - u~
    !> (+ k a for generalized-alpha, k = beta dt^2 am/(1-am)), the vector whose product
    !> with M enters the Newton residual.
    pure subroutine form_predictor(this, u, v, a)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme (ut, dvec set)
        real(dp), intent(in) :: u(:)                        !! displacement
        real(dp), intent(in) :: v(:)                        !! velocity
        real(dp), intent(in) :: a(:)                        !! acceleration (Newmark family)
        real(dp) :: c1, k
        integer :: i
        if (this%kind == KIND_NEWMARK) then
            c1 = this%dt**2 * (0.5_dp - this%beta)
            do i = 1, size(u)
                this%ut(i) = u(i) + this%dt * v(i) + c1 * a(i)
                this%dvec(i) = u(i) - this%ut(i)
            end do
            if (this%alpha_m /= 0.0_dp) then
                k = this%beta * this%dt**2 * this%alpha_m / (1.0_dp - this%alpha_m)
                this%dvec = this%dvec + k * a
            end if
        else
            do i = 1, size(u)
                this%ut(i) = u(i) + this%dt * v(i)
                this%dvec(i) = u(i) - this%ut(i)
            end do
        end if
    end subroutine form_predictor
end module implicit_schemes
