!> Semi-smooth Newton on (u, lambda) for the augmented Lagrangian (fem/alm_contact.f90) in
!> an implicit step. The step's equations are
!>     R(x, lambda) = M (x - u~) + c (K x - N lambda) - b = 0,   G(x, lambda) = 0,
!> and one Newton iteration solves
!>     [ J0   -c N ] [dx]     [R]
!>     [ A_u   A_l ] [dl] = - [G],      J0 = M + c K (factorized once by the scheme).
!> Through the factor of J0 and the Schur complement on the multipliers:
!>     dx = -J0^{-1} R + c Z N dl,   (c A_u W N + A_l) dl = -G + A_u P J0^{-1} R,
!> with Z = J0^{-1} P^T and W = P Z on the contact-cell dofs (P restricts to them), both
!> precomputed by the scheme for the Woodbury correction. S = c A_u W N + A_l is nl x nl
!> (nl = contact nodes), solved by dense LU. R is linear: after the first iteration it is
!> zero (the step solved it exactly), so the later iterations run on the contact-cell dofs
!> and the multipliers alone, and x = u^n - y0 + c Z N (lambda' - lambda^n),
!> y0 = J0^{-1} R(u^n, lambda^n): one sparse solve a step, as for Nitsche. Newton stops
!> when |G| <= tol s, s the largest over the step's iterates (the start included) of
!> | |A_u| |P x| | + | |A_l| |lambda| |, the norms of G's two terms: G is piecewise linear,
!> so once the active set is right the next iterate solves it to round-off; the scale
!> must not shrink with the iterate (a released node's lambda goes to 0 and with it the
!> second term).
module alm_newton
    use kinds, only: dp, i8
    use text, only: int_text, real_text, counted
    use errors, only: STAT_OK, STAT_NUMERIC, raise
    use dense_lu, only: dense_lu_factor, dense_lu_solve
    use model, only: model_t
    use alm_contact, only: alm_eval, alm_force
    implicit none
    private

    !> Work arrays and W N of the Newton iterations on (u, lambda).
    type, public :: alm_newton_t
        integer :: m = 0                           !! contact-cell dofs
        integer :: nl = 0                          !! multipliers
        real(dp), allocatable :: wn(:, :)          !! (m, nl) W N
        real(dp), allocatable :: g(:)              !! (nl) G at the iterate
        real(dp), allocatable :: au(:, :)          !! (nl, m) dG/du
        real(dp), allocatable :: al(:, :)          !! (nl, nl) dG/dlambda
        real(dp), allocatable :: s(:, :)           !! (nl, nl) Schur complement
        real(dp), allocatable :: dl(:)             !! (nl) multiplier step
        real(dp), allocatable :: lk(:)             !! (nl) multipliers at the iterate
        real(dp), allocatable :: xk(:)             !! (m) P x at the iterate
        integer, allocatable :: piv(:)             !! (nl) pivots
    end type alm_newton_t

    public :: alm_newton_init, alm_newton_solve

contains

    !> W N and the work arrays (w = P J0^{-1} P^T from the scheme).
    pure subroutine alm_newton_init(an, mdl, w)
        type(alm_newton_t), intent(out) :: an    !! Newton data
        type(model_t), intent(in) :: mdl         !! model (mdl%alm set)
        real(dp), intent(in) :: w(:, :)          !! (m, m) W
        an%m = size(w, 1)
        an%nl = mdl%alm%nl
        allocate (an%g(an%nl), an%au(an%nl, an%m), an%al(an%nl, an%nl), an%s(an%nl, an%nl), &
                  an%dl(an%nl), an%lk(an%nl), an%xk(an%m), an%piv(an%nl))
        an%wn = matmul(w, mdl%alm%nmat)
    end subroutine alm_newton_init

    !> Newton on (x, lambda) from (u^n, lambda^n). x0c = P u^n, y0c = P J0^{-1} R(u^n,
    !> lambda^n). Returns T with x = u^n - y0 - Z T, the new multipliers lam, the contact
    !> part cx = -N lam of B on the contact-cell dofs, the active points and the iterations.
    subroutine alm_newton_solve(an, mdl, c, tol, maxit, t, x0c, y0c, lam, tcoef, cx, active, &
                                it, stat, errmsg)
        type(alm_newton_t), intent(inout) :: an  !! Newton data
        type(model_t), intent(in) :: mdl         !! model
        real(dp), intent(in) :: c                !! coefficient of B in R
        real(dp), intent(in) :: tol              !! relative tolerance on G
        integer, intent(in) :: maxit             !! iteration limit
        real(dp), intent(in) :: t                !! time at the step's end (messages)
        real(dp), intent(in) :: x0c(:)           !! (m) P u^n
        real(dp), intent(in) :: y0c(:)           !! (m) P J0^{-1} R(u^n, lambda^n)
        real(dp), intent(inout) :: lam(:)        !! (nl) lambda^n -> lambda^{n+1}
        real(dp), intent(out) :: tcoef(:)        !! (m) T
        real(dp), intent(out) :: cx(:)           !! (m) -N lambda^{n+1}
        integer, intent(out) :: active           !! active points at the solution
        integer, intent(out) :: it               !! Newton iterations
        integer, intent(out) :: stat             !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: gnorm, scale
        integer :: info, l
        stat = STAT_OK
        an%xk = x0c
        an%lk = lam
        call alm_eval(mdl%alm, mdl%ct, an%xk, an%lk, an%g, an%au, an%al, active)
        it = 0
        gnorm = huge(1.0_dp)
        scale = term_scale()
        do
            if (it >= maxit .or. .not. (gnorm == gnorm)) then
                call raise(stat, errmsg, STAT_NUMERIC, 'Newton (augmented Lagrangian) did not ' &
                           //'converge at t = '//real_text(t, 6)//' after ' &
                           //counted(int(it, i8), 'iteration')//' (relative residual '// &
                           real_text(gnorm / max(scale, tiny(1.0_dp)), 4)//')')
                return
            end if
            ! S dl = -G + A_u P y (P y = y0c on the first iteration, 0 after it)
            an%s = c * matmul(an%au, an%wn) + an%al
            an%dl = -an%g
            if (it == 0) an%dl = an%dl + matmul(an%au, y0c)
            call dense_lu_factor(an%nl, an%s, an%piv, info)
            if (info /= 0) then
                call raise(stat, errmsg, STAT_NUMERIC, 'singular multiplier system in Newton ' &
                           //'(augmented Lagrangian) at t = '//real_text(t, 6))
                return
            end if
            call dense_lu_solve(an%nl, an%s, an%piv, an%dl)
            ! P dx = -P y + c W N dl
            if (it == 0) an%xk = an%xk - y0c
            an%xk = an%xk + c * matmul(an%wn, an%dl)
            an%lk = an%lk + an%dl
            it = it + 1
            call alm_eval(mdl%alm, mdl%ct, an%xk, an%lk, an%g, an%au, an%al, active)
            gnorm = norm2(an%g)
            if (gnorm == 0.0_dp) exit
            scale = max(scale, term_scale())
            if (gnorm <= tol * scale) exit
        end do
        ! x = u^n - y0 + c Z N (lambda' - lambda^n) = u^n - y0 - Z T
        an%dl = an%lk - lam
        tcoef = 0.0_dp
        do l = 1, an%nl
            tcoef = tcoef - c * an%dl(l) * mdl%alm%nmat(:, l)
        end do
        lam = an%lk
        call alm_force(mdl%alm, lam, cx)

    contains

        !> | |A_u| |P x| | + | |A_l| |lambda| |: the norms of G's two terms at the iterate.
        pure real(dp) function term_scale()
            real(dp) :: s1, s2
            integer :: i
            s1 = 0.0_dp; s2 = 0.0_dp
            do i = 1, an%nl
                s1 = s1 + dot_product(abs(an%au(i, :)), abs(an%xk))**2
                s2 = s2 + dot_product(abs(an%al(i, :)), abs(an%lk))**2
            end do
            term_scale = sqrt(s1) + sqrt(s2)
        end function term_scale
    end subroutine alm_newton_solve
end module alm_newton
