!> The augmented Lagrangian (Alart-Curnier) for frictionless contact with a rigid plane.
!> Unknowns u (P1) and a multiplier lambda at each contact node, r = gamma0 / h_T:
!>   m(u'', v) + a(u, v) - <lambda, v_n> = L(v),
!>   'integral': lambda P1 on Gamma_C (lambda = sigma_n), <lambda, v_n> = int lambda v_n and
!>     G_J = int (1/r) (lambda - min(lambda - r (u_n - g), 0)) psi_J = 0 on the contact
!>     quadrature ('gauss': quad_points points a facet; 'exact': the facet split at the
!>     zero of lambda - r (u_n - g), which is linear on it, 2 Gauss points a piece of a
!>     segment, the 3-point degree-2 rule on each triangle of a split triangle facet, so
!>     G is integrated exactly);
!>   'nodal': lambda_i a force at contact node i, <lambda, v_n> = sum_i lambda_i v_n(x_i) and
!>     G_i = (1/r_i) (lambda_i - min(lambda_i - r_i (u_n(x_i) - g_i), 0)) = 0, r_i the mean
!>     gamma0 / h_T of the node's facets: u_n <= g, lambda <= 0, lambda (u_n - g) = 0 exactly
!>     at the nodes, whatever r (r only steers Newton).
!> In both, the contact part of B on the contact-cell dofs (contact_t cdofs) is -N lambda with
!> a constant N (m x nl): N(l, J) = int psi_J (phi_l . n) ('integral', exact: degree 2) or the
!> normal component of node J at its dofs ('nodal'). G is piecewise linear in (u, lambda); its
!> generalized derivative is A_u = dG/du (nl x m, on the contact-cell dofs) and
!> A_l = dG/dlambda (nl x nl): at an active point (lambda - r (u_n - g) < 0) the integrand is
!> u_n - g, at an inactive one lambda / r.
module alm_contact
    use kinds, only: dp
    use nitsche_contact, only: contact_t, facet_shape, triangle_active_rule, MAX_E, MAX_FN, MAX_Q, &
                               QUAD_EXACT
    implicit none
    private

    integer, parameter, public :: ALM_OFF = 0        !! no multipliers (Nitsche or penalty)
    integer, parameter, public :: ALM_INTEGRAL = 1   !! lambda P1 on Gamma_C
    integer, parameter, public :: ALM_NODAL = 2      !! lambda_i a nodal force

    !> Multipliers on the contact nodes and the constant coupling N.
    type, public :: alm_t
        integer :: kind = ALM_OFF                !! ALM_OFF | ALM_INTEGRAL | ALM_NODAL
        integer :: nl = 0                        !! multipliers (contact nodes)
        integer, allocatable :: node(:)          !! (nl) mesh node of each multiplier
        integer, allocatable :: lnode(:, :)      !! (nfn, n_facets) multiplier of facet node j
        real(dp), allocatable :: share(:)        !! (nl) the node's share of Gamma_C
        real(dp), allocatable :: rnode(:)        !! (nl) nodal r: mean gamma0 / h_T of its facets
        real(dp), allocatable :: gnode(:)        !! (nl) initial gap at the node
        real(dp), allocatable :: nmat(:, :)      !! (m, nl) N; the contact part of B is -N lambda
    end type alm_t

    public :: alm_init, alm_eval, alm_force, alm_probe, alm_resultant

contains

    !> Number the contact nodes (in the order the facets first name them), their shares of
    !> Gamma_C, nodal r and gaps, and N.
    pure subroutine alm_init(alm, ct, kind)
        type(alm_t), intent(out) :: alm          !! multipliers
        type(contact_t), intent(in) :: ct        !! contact facets
        integer, intent(in) :: kind              !! ALM_INTEGRAL or ALM_NODAL
        integer :: f, j, k, l, i, nmax, cnt
        integer, allocatable :: seen(:), nodes(:)
        real(dp) :: nsh(MAX_FN), xs(2), nn, shp(MAX_FN, MAX_Q), ws(MAX_Q)
        integer :: np
        integer, allocatable :: nfac(:)
        alm%kind = kind
        nmax = 0
        if (ct%n_facets > 0) nmax = maxval(ct%nodes)
        allocate (seen(nmax), nodes(ct%nfn * ct%n_facets), alm%lnode(ct%nfn, ct%n_facets))
        seen = 0
        cnt = 0
        do f = 1, ct%n_facets
            do j = 1, ct%nfn
                k = ct%nodes(j, f)
                if (seen(k) == 0) then
                    cnt = cnt + 1
                    seen(k) = cnt
                    nodes(cnt) = k
                end if
                alm%lnode(j, f) = seen(k)
            end do
        end do
        alm%nl = cnt
        alm%node = nodes(1:cnt)
        allocate (alm%share(cnt), alm%rnode(cnt), alm%gnode(cnt), alm%nmat(ct%m, cnt), nfac(cnt))
        alm%share = 0.0_dp; alm%rnode = 0.0_dp; nfac = 0
        alm%nmat = 0.0_dp
        xs = 0.5_dp + [-0.5_dp, 0.5_dp] / sqrt(3.0_dp)
        do f = 1, ct%n_facets
            do j = 1, ct%nfn
                l = alm%lnode(j, f)
                alm%share(l) = alm%share(l) + ct%measure(f) / ct%nfn
                alm%rnode(l) = alm%rnode(l) + ct%gamma(f)
                nfac(l) = nfac(l) + 1
                alm%gnode(l) = ct%gap(j, f)
                if (kind == ALM_NODAL) then
                    do i = 1, ct%ndof_e
                        if (ct%cloc(i, f) > 0 .and. ct%nvec(i, j, f) /= 0.0_dp) &
                            alm%nmat(ct%cloc(i, f), l) = ct%nvec(i, j, f)
                    end do
                end if
            end do
            if (kind == ALM_INTEGRAL) then
                ! int psi_J (phi_i . n): degree 2 on the facet; 2 Gauss points on a segment,
                ! the 3-point degree-2 rule on a triangle are exact
                if (ct%nfn == 1) then
                    np = 1; shp(:, 1) = facet_shape(1, 0.0_dp); ws(1) = ct%measure(f)
                else if (ct%nfn == 2) then
                    np = 2; ws(1:2) = 0.5_dp * ct%measure(f)
                    shp(:, 1) = facet_shape(2, xs(1)); shp(:, 2) = facet_shape(2, xs(2))
                else
                    call triangle_active_rule([-1.0_dp, -1.0_dp, -1.0_dp], ct%measure(f), np, &
                                              shp, ws)
                end if
                do k = 1, np
                    nsh = shp(:, k)
                    do i = 1, ct%ndof_e
                        if (ct%cloc(i, f) == 0) cycle
                        nn = dot_product(ct%nvec(i, 1:ct%nfn, f), nsh(1:ct%nfn))
                        do j = 1, ct%nfn
                            l = alm%lnode(j, f)
                            alm%nmat(ct%cloc(i, f), l) = alm%nmat(ct%cloc(i, f), l) + &
                                ws(k) * nsh(j) * nn
                        end do
                    end do
                end do
            end if
        end do
        alm%rnode = alm%rnode / max(nfac, 1)
    end subroutine alm_init

    !> The complementarity residual G(u, lambda) (nl), its generalized derivative A_u (nl x m,
    !> on the contact-cell dofs) and A_l (nl x nl), and the active points (quadrature points
    !> for 'integral', nodes for 'nodal'). xc = u on the contact-cell dofs (ct%cdofs).
    pure subroutine alm_eval(alm, ct, xc, lam, g, au, al, active)
        type(alm_t), intent(in) :: alm           !! multipliers
        type(contact_t), intent(in) :: ct        !! contact facets
        real(dp), intent(in) :: xc(:)            !! (m) u on the contact-cell dofs
        real(dp), intent(in) :: lam(:)           !! (nl) multipliers
        real(dp), intent(out) :: g(:)            !! (nl) G
        real(dp), intent(out) :: au(:, :)        !! (nl, m) dG/du
        real(dp), intent(out) :: al(:, :)        !! (nl, nl) dG/dlambda
        integer, intent(out) :: active           !! active points
        real(dp) :: ue(MAX_E), un(MAX_FN), lj(MAX_FN), pj(MAX_FN), nsh(MAX_FN), nn(MAX_E)
        real(dp) :: shp(MAX_FN, 2 * MAX_Q), ws(2 * MAX_Q), r, pq, unq, lq, xi_star
        logical :: act(2 * MAX_Q), signed
        integer :: f, i, j, k, q, np, l, nf, na
        g = 0.0_dp; au = 0.0_dp; al = 0.0_dp
        active = 0
        if (alm%kind == ALM_NODAL) then
            do l = 1, alm%nl
                unq = dot_product(alm%nmat(:, l), xc) - alm%gnode(l)
                r = alm%rnode(l)
                if (lam(l) - r * unq < 0.0_dp) then
                    active = active + 1
                    g(l) = unq
                    au(l, :) = alm%nmat(:, l)
                else
                    g(l) = lam(l) / r
                    al(l, l) = 1.0_dp / r
                end if
            end do
            return
        end if
        nf = ct%nfn
        do f = 1, ct%n_facets
            do i = 1, ct%ndof_e
                ue(i) = 0.0_dp
                if (ct%cloc(i, f) > 0) ue(i) = xc(ct%cloc(i, f))
            end do
            r = ct%gamma(f)
            do j = 1, nf
                un(j) = dot_product(ue(1:ct%ndof_e), ct%nvec(1:ct%ndof_e, j, f)) - ct%gap(j, f)
                lj(j) = lam(alm%lnode(j, f))
                pj(j) = lj(j) - r * un(j)
            end do
            ! the points: one in 1D; the Gauss rule; or, 'exact', the facet split at the zero
            ! of the linear P = lambda - r (u_n - g): 2 Gauss points on each side of it on a
            ! segment, the degree-2 rule on each piece of a triangle (signed: the side of
            ! each point is known, act)
            signed = .false.
            if (nf == 1) then
                np = 1; shp(:, 1) = facet_shape(1, 0.0_dp); ws(1) = ct%measure(f)
            else if (ct%quad /= QUAD_EXACT) then
                np = ct%nq; shp(:, 1:np) = ct%qs(:, 1:np); ws(1:np) = ct%measure(f) * ct%qw(1:np)
            else if (nf == 3) then
                signed = .true.
                call triangle_active_rule(pj(1:3), ct%measure(f), na, shp, ws)
                act(1:na) = .true.
                if (all(pj(1:3) >= 0.0_dp)) then    ! all inactive (P = 0 counts as inactive)
                    call triangle_active_rule([-1.0_dp, -1.0_dp, -1.0_dp], ct%measure(f), np, &
                                              shp(:, na + 1:), ws(na + 1:))
                else
                    call triangle_active_rule(-pj(1:3), ct%measure(f), np, shp(:, na + 1:), &
                                              ws(na + 1:))
                end if
                act(na + 1:na + np) = .false.
                np = na + np
            else if ((pj(1) < 0.0_dp) .eqv. (pj(2) < 0.0_dp)) then
                np = 2
                call piece(0.0_dp, 1.0_dp, ct%measure(f), shp(:, 1:2), ws(1:2))
            else
                np = 4
                signed = .true.
                xi_star = pj(1) / (pj(1) - pj(2))
                call piece(0.0_dp, xi_star, ct%measure(f), shp(:, 1:2), ws(1:2))
                call piece(xi_star, 1.0_dp, ct%measure(f), shp(:, 3:4), ws(3:4))
                act(1:2) = pj(1) < 0.0_dp
                act(3:4) = .not. act(1)
            end if
            do q = 1, np
                nsh = shp(:, q)
                unq = dot_product(nsh(1:nf), un(1:nf))
                lq = dot_product(nsh(1:nf), lj(1:nf))
                pq = lq - r * unq
                if (signed) pq = merge(-1.0_dp, 1.0_dp, act(q))
                if (pq < 0.0_dp) then
                    active = active + 1
                    do i = 1, ct%ndof_e
                        nn(i) = dot_product(ct%nvec(i, 1:nf, f), nsh(1:nf))
                    end do
                    do j = 1, nf
                        l = alm%lnode(j, f)
                        g(l) = g(l) + ws(q) * nsh(j) * unq
                        do i = 1, ct%ndof_e
                            if (ct%cloc(i, f) > 0) au(l, ct%cloc(i, f)) = au(l, ct%cloc(i, f)) &
                                + ws(q) * nsh(j) * nn(i)
                        end do
                    end do
                else
                    do j = 1, nf
                        l = alm%lnode(j, f)
                        g(l) = g(l) + ws(q) * nsh(j) * lq / r
                        do k = 1, nf
                            al(l, alm%lnode(k, f)) = al(l, alm%lnode(k, f)) &
                                + ws(q) * nsh(j) * nsh(k) / r
                        end do
                    end do
                end if
            end do
        end do

    contains

        !> 2 Gauss points on [a, b] of a segment facet of length meas: shape values and
        !> weights (times meas).
        pure subroutine piece(a, b, meas, shp2, w2)
            real(dp), intent(in) :: a, b, meas          !! piece [a, b] of the facet; its length
            real(dp), intent(out) :: shp2(:, :), w2(:)  !! shape values (node, point); weights
            real(dp) :: x2(2)
            x2 = a + (b - a) * (0.5_dp + [-0.5_dp, 0.5_dp] / sqrt(3.0_dp))
            shp2(:, 1) = facet_shape(2, x2(1))
            shp2(:, 2) = facet_shape(2, x2(2))
            w2 = 0.5_dp * (b - a) * meas
        end subroutine piece
    end subroutine alm_eval

    !> The contact part of B on the contact-cell dofs: f = -N lambda.
    pure subroutine alm_force(alm, lam, f)
        type(alm_t), intent(in) :: alm           !! multipliers
        real(dp), intent(in) :: lam(:)           !! (nl) multipliers
        real(dp), intent(out) :: f(:)            !! (m) -N lambda
        integer :: l
        f = 0.0_dp
        do l = 1, alm%nl
            f = f - lam(l) * alm%nmat(:, l)
        end do
    end subroutine alm_force

    !> The total normal contact force of the multipliers (<= 0, p_n's sign): 'integral'
    !> int_GammaC lambda = sum_l share_l lambda_l (int psi_l = the node's share, exact for
    !> P1 lambda); 'nodal' sum_l lambda_l. Against the rigid translation along n the
    !> contact part -N lambda gives minus it (N's column l against the translation is
    !> share_l, or 1: n . n = 1 at the node's dofs, when none of them is constrained).
    pure real(dp) function alm_resultant(alm, lam) result(f_n)
        type(alm_t), intent(in) :: alm           !! multipliers
        real(dp), intent(in) :: lam(:)           !! (nl) multipliers
        integer :: l
        f_n = 0.0_dp
        if (alm%kind == ALM_NODAL) then
            do l = 1, alm%nl
                f_n = f_n + lam(l)
            end do
        else
            do l = 1, alm%nl
                f_n = f_n + alm%share(l) * lam(l)
            end do
        end if
    end function alm_resultant

    !> The contact stress at a point of facet f (its facet shape values nsh): lambda
    !> interpolated ('integral'), or the nodal force over the node's share of Gamma_C,
    !> interpolated ('nodal').
    pure real(dp) function alm_probe(alm, ct, lam, f, nsh) result(p)
        type(alm_t), intent(in) :: alm           !! multipliers
        type(contact_t), intent(in) :: ct        !! contact facets
        real(dp), intent(in) :: lam(:)           !! (nl) multipliers
        integer, intent(in) :: f                 !! facet
        real(dp), intent(in) :: nsh(MAX_FN)      !! facet shape values at the point
        integer :: j, l
        p = 0.0_dp
        do j = 1, ct%nfn
            l = alm%lnode(j, f)
            if (alm%kind == ALM_NODAL) then
                p = p + nsh(j) * lam(l) / alm%share(l)
            else
                p = p + nsh(j) * lam(l)
            end if
        end do
    end function alm_probe
end module alm_contact
