!> Unit tests of module alm_contact: the generalized derivative (A_u, A_l) of the
!> augmented Lagrangian's complementarity residual G(u, lambda) against central finite
!> differences on random states with active and inactive points (components whose
!> perturbation changes the active set are skipped: G has a kink there), in 1D, 2D and 3D
!> (points, segments, triangles), for 'integral' (both contact quadratures) and 'nodal'
!> multipliers; and the contact force
!> -N lambda against N applied column by column (it is linear in lambda).
!> Exit status 1 (error stop) on any failure.
program test_alm_contact
    use kinds, only: dp
    use mesh, only: mesh_t
    use bar_mesh, only: bar_mesh_build
    use model, only: model_t, model_params_t, model_build
    use nitsche_contact, only: QUAD_EXACT, QUAD_GAUSS
    use alm_contact, only: alm_eval, alm_force, ALM_INTEGRAL, ALM_NODAL
    use unit_checks, only: checks_t, seed
    implicit none
    real(dp), parameter :: STEP = 1.0e-7_dp
    !> central differences of a piecewise linear function on a linear piece: exact but for
    !> round-off (about eps / STEP relative)
    real(dp), parameter :: FD_TOL = 1.0e-6_dp
    type(checks_t) :: checks
    integer :: dim, kind, quad

    call seed(5)
    do dim = 1, 3
        do kind = ALM_INTEGRAL, ALM_NODAL
            do quad = QUAD_EXACT, QUAD_GAUSS
                if (kind == ALM_NODAL .and. quad == QUAD_GAUSS) cycle
                call check_case(dim, kind, quad)
            end do
        end do
    end do
    call checks%finish('test_alm_contact')

contains

    subroutine check_case(dim, kind, quad)
        integer, intent(in) :: dim, kind, quad
        type(mesh_t) :: msh
        type(model_params_t) :: prm
        type(model_t) :: mdl
        integer :: stat, m, nl, k, trial, act0, nchecked, nact
        logical :: inactive_seen
        real(dp), allocatable :: xc(:), lam(:), g(:), au(:, :), al(:, :), col(:), f0(:), f1(:)
        real(dp) :: err, scale, width
        character(len=64) :: tag
        character(len=256) :: msg
        write (tag, '(a, i0, a, i0, a, i0)') ' dim ', dim, ' multiplier ', kind, ' quadrature ', quad
        width = merge(0.1_dp, 0.2_dp, dim == 3)
        call bar_mesh_build(dim, 1.0_dp, width, 0.05_dp, msh, stat, msg)
        call checks%check(stat == 0, 'mesh'//trim(tag))
        prm%clamped = 'top'; prm%contact = 'bottom'
        prm%young = 2.0_dp / 3.0_dp; prm%poisson = 1.0_dp / 3.0_dp
        prm%multiplier = kind; prm%quadrature = quad; prm%quad_points = 3
        prm%gamma0 = 10.0_dp
        select case (dim)
        case (1)
            prm%obstacle_normal = [-1.0_dp, 0.0_dp, 0.0_dp]; prm%probe = 0.0_dp
        case (2)
            prm%obstacle_normal = [0.0_dp, -1.0_dp, 0.0_dp]; prm%probe = [0.1_dp, 0.0_dp, 0.0_dp]
        case default
            prm%obstacle_normal = [0.0_dp, 0.0_dp, -1.0_dp]; prm%probe = [0.05_dp, 0.05_dp, 0.0_dp]
        end select
        call model_build(msh, prm, mdl, stat, msg)
        call checks%check(stat == 0, 'model'//trim(tag)//': '//trim(msg))
        if (stat /= 0) return
        m = mdl%ct%m; nl = mdl%alm%nl
        call checks%check(nl == nint(width / 0.05_dp + 1)**(dim - 1), 'multipliers on the contact nodes'//trim(tag))
        allocate (xc(m), lam(nl), g(nl), au(nl, m), al(nl, nl), col(nl), f0(m), f1(m))
        nchecked = 0; nact = 0; inactive_seen = .false.
        do trial = 1, 20
            ! u of order 0.01, lambda in (-1, 0.5): r (u_n - g) of order 2 against lambda,
            ! so both active and inactive points occur
            call random_number(xc); xc = 0.02_dp * (xc - 0.5_dp)
            call random_number(lam); lam = 1.5_dp * lam - 1.0_dp
            call alm_eval(mdl%alm, mdl%ct, xc, lam, g, au, al, act0)
            nact = nact + act0
            inactive_seen = inactive_seen .or. any(al /= 0.0_dp)
            scale = maxval(abs(au)) + maxval(abs(al))
            do k = 1, m + nl    ! d/du_k, then d/dlambda_(k-m)
                if (.not. fd_column(mdl, xc, lam, k, m, act0, col)) cycle
                if (k <= m) then
                    err = maxval(abs(col - au(:, k))) / scale
                else
                    err = maxval(abs(col - al(:, k - m))) / scale
                end if
                call checks%check(err < FD_TOL, merge('dG/du      ', 'dG/dlambda ', k <= m)// &
                                  'by finite differences'//trim(tag))
                nchecked = nchecked + 1
            end do
            ! -N lambda: linear, column k of -N by a unit change of lambda_k
            call alm_force(mdl%alm, lam, f0)
            do k = 1, nl
                lam(k) = lam(k) + 1.0_dp
                call alm_force(mdl%alm, lam, f1)
                lam(k) = lam(k) - 1.0_dp
                call checks%check(maxval(abs(f1 - f0 + mdl%alm%nmat(:, k))) < 1.0e-14_dp, &
                                  'contact force -N lambda'//trim(tag))
            end do
        end do
        call checks%check(nchecked > 20 * (m + nl) / 2, 'most components checked'//trim(tag))
        call checks%check(nact > 0 .and. inactive_seen, 'active and inactive points'//trim(tag))
        ! integral multipliers: N sums to the contact boundary's measure in the normal
        ! direction (int psi_J (phi . n) summed over J and the dofs' normal components)
        if (kind == ALM_INTEGRAL) call checks%check(abs(sum(mdl%alm%nmat) &
            + width**(dim - 1)) < 1.0e-13_dp, 'N sums to -|Gamma_C|'//trim(tag))
    end subroutine check_case

    !> Central difference of G along u_k (k <= m) or lambda_(k-m) into col; false when the
    !> perturbation changes the count of active points (a kink of G: not compared).
    logical function fd_column(mdl, xc, lam, k, m, act0, col) result(same)
        type(model_t), intent(in) :: mdl
        real(dp), intent(in) :: xc(:), lam(:)
        integer, intent(in) :: k, m, act0
        real(dp), intent(out) :: col(:)
        real(dp) :: gp(size(lam)), gm(size(lam)), aup(size(lam), size(xc)), &
                    alp(size(lam), size(lam)), du(size(xc)), dl(size(lam))
        integer :: actp, actm
        du = 0.0_dp; dl = 0.0_dp
        if (k <= m) then
            du(k) = STEP
        else
            dl(k - m) = STEP
        end if
        call alm_eval(mdl%alm, mdl%ct, xc + du, lam + dl, gp, aup, alp, actp)
        call alm_eval(mdl%alm, mdl%ct, xc - du, lam - dl, gm, aup, alp, actm)
        col = (gp - gm) / (2.0_dp * STEP)
        same = actp == act0 .and. actm == act0
    end function fd_column
end program test_alm_contact
