!> Nitsche's method for frictionless contact with a rigid plane (SPEC section 1):
!> B(u).v = a_theta(u, v) + int_GammaC (1/gamma_N) [P_1(u) + gamma_N g]_- P_theta(v),
!> P_theta(v) = theta sigma_n(v) - gamma_N v_n. This module holds the nonlinear facet
!> part; the linear -theta/gamma_N sigma_n(u) sigma_n(v) part is assembled into K_theta.
!>
!> On a P1 facet sigma_n(u) is constant (it lives on the owner cell) and u_n, g are
!> linear, so P(xi) = P_1(u) + gamma_N g is linear along the facet. Quadrature
!> 'exact' splits the facet at the zero of P and integrates the active piece exactly
!> (the residual, the tangent and the energy are polynomials of degree <= 2 on it):
!> on a segment (2D) 2 Gauss points on the active sub-segment; on a triangle (3D) the
!> active part {P < 0} is cut by the zero line into a triangle or a quadrilateral
!> (two triangles), each integrated with the symmetric 3-point rule of degree 2.
!> 'gauss' uses a fixed rule on the whole facet, which does not resolve the kink:
!> quad_points Gauss-Legendre points on a segment (GetFEM's 2D reference runs used 3),
!> the symmetric triangle rules with 1, 3, 6 or 7 points (degree 1, 2, 4, 5; 7 is the
!> face rule of GetFEM's 3D reference runs).
!>
!> Penalty contact (`&contact method = 'penalty'`, eps_N = gamma0 / h_T) is the same
!> term with the sigma_n parts removed: P(u) = -eps_N (u_n - g), theta = 0, so
!> B(u).v = a(u, v) + int eps_N [u_n - g]_+ v_n and the contact energy is
!> int (eps_N / 2) [u_n - g]_+^2 = int (1/(2 eps_N)) [P]_-^2: the facet kernels serve
!> both, with s = 0.
module nitsche_contact
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_INTERNAL, raise
    use mesh, only: mesh_t
    use fe_p1, only: p1_gradients
    use simplex_geometry, only: simplex_diameter, euclid_length
    implicit none
    private

    integer, parameter, public :: QUAD_EXACT = 1   !! split at the kink
    integer, parameter, public :: QUAD_GAUSS = 2   !! fixed Gauss rule
    !> Largest owner-cell dofs (dim (dim+1), dim <= 3), facet nodes and quadrature
    !> points of a facet: the facet kernels' local arrays have these fixed sizes
    !> (run-time sizes put them on the heap, one malloc a facet).
    integer, parameter, public :: MAX_E = 12
    integer, parameter, public :: MAX_FN = 3
    integer, parameter, public :: MAX_Q = 7
    !> Dofs of a 2D owner cell (a P1 triangle): ndof_e whenever nfn = 2 (contact_init
    !> sets ndof_e = dim (dim + 1), nfn = dim), a length known when compiled
    integer, parameter, public :: E_2D = 6

    !> Contact facets with everything constant precomputed.
    type, public :: contact_t
        integer :: dim = 0                    !! 1, 2 or 3
        integer :: n_facets = 0               !! contact facets
        integer :: ndof_e = 0                 !! dofs of an owner cell: dim (dim+1)
        integer :: nfn = 0                    !! nodes per facet: dim
        integer :: theta = 1                  !! Nitsche theta in {-1, 0, 1}
        integer :: quad = QUAD_EXACT          !! QUAD_EXACT or QUAD_GAUSS
        integer :: nq = 0                     !! Gauss points (QUAD_GAUSS)
        real(dp) :: qs(MAX_FN, MAX_Q) = 0.0_dp !! facet shape values at the Gauss points
        real(dp) :: qw(MAX_Q) = 0.0_dp        !! Gauss weights (sum 1)
        integer, allocatable :: cell(:)       !! (n_facets) owner cell
        integer, allocatable :: nodes(:, :)   !! (nfn, n_facets) facet nodes (global)
        integer, allocatable :: dofs(:, :)    !! (ndof_e, n_facets) owner free dofs, 0 = constrained
        real(dp), allocatable :: s(:, :)      !! (ndof_e, n_facets) sigma_n(v) = s . v_e
        real(dp), allocatable :: nvec(:, :, :) !! (ndof_e, nfn, n_facets) v_n at facet node j = nvec(:, j) . v_e
        real(dp), allocatable :: gap(:, :)    !! (nfn, n_facets) initial gap g >= 0 at facet nodes
        real(dp), allocatable :: gamma(:)     !! (n_facets) gamma_N = gamma0 / h_T
        real(dp), allocatable :: measure(:)   !! (n_facets) facet length (2D), area (3D), 1 in 1D
        integer :: m = 0                      !! distinct free dofs of all owner cells
        integer, allocatable :: cdofs(:)      !! (m) those free dofs
        integer, allocatable :: cloc(:, :)    !! (ndof_e, n_facets) index into cdofs, 0 = constrained
    end type contact_t

    public :: contact_init, contact_eval, contact_clear, contact_max_rank, nitsche_facet, &
              facet_pressure, facet_shape, triangle_rule, triangle_active_rule

contains

    !> Values of a segment facet's nodal shape functions at xi in [0, 1] (1 in 1D).
    pure function facet_shape(nfn, xi) result(nsh)
        integer, intent(in) :: nfn     !! nodes per facet (1 or 2)
        real(dp), intent(in) :: xi     !! position along the facet
        real(dp) :: nsh(MAX_FN)        !! the first nfn entries (the rest 0)
        nsh = 0.0_dp
        if (nfn == 1) then
            nsh(1) = 1.0_dp
        else
            nsh(1:2) = [1.0_dp - xi, xi]
        end if
    end function facet_shape

    !> Residual, generalized tangent and penalty energy of one contact facet.
    !> r = int (1/gamma) [P]_- P_theta; the tangent dr/du_e = sum_q qa_q qb_q^T over the
    !> active points (rank one each); energy = int (1/(2 gamma)) [P]_-^2.
    !> With nterm present the tangent comes in at most nfn terms instead (nterm of them):
    !> the facet shape values sum to 1, so at a point P_theta = Mt nsh and dP/du_e = M nsh
    !> with the columns Mt(:, j) = theta s - gamma nvec(:, j), M(:, j) = s - gamma nvec(:, j),
    !> and sum_q (w_q/gamma) (Mt nsh_q) (M nsh_q)^T = Mt G M^T, G = sum_q (w_q/gamma)
    !> nsh_q nsh_q^T (nfn x nfn): qa_j = Mt G(:, j), qb_j = M(:, j), the same tangent to
    !> round-off. Used when more than nfn points are active (a 3D facet: 3 terms where its
    !> rule has up to 6 or 7 points), else the terms are the points' (nterm = active).
    !> Either way each term is qa_t = Mt ca_t, qb_t = M cb_t (to round-off) with the nfn
    !> coefficients ca_t, cb_t (a point: (w/gamma) nsh and nsh; a compressed term j:
    !> G(:, j) and e_j), returned in ca, cb when present (with nterm). The residual is
    !> r = Mt rg (to round-off) with rg = sum_q (w_q/gamma) P_q nsh_q, returned in rg when
    !> present (zero on an inactive facet).
    pure subroutine nitsche_facet(ndof_e, nfn, ue, s, nvec, gap, gamma, theta, measure, &
                                  quad, nq, qs, qw, r, energy, active, qa, qb, nterm, ca, cb, &
                                  rg)
        integer, intent(in) :: ndof_e          !! owner cell dofs
        integer, intent(in) :: nfn             !! facet nodes (1 in 1D, 2 in 2D, 3 in 3D)
        real(dp), intent(in) :: ue(ndof_e)     !! owner cell displacement
        real(dp), intent(in) :: s(ndof_e)      !! sigma_n row
        real(dp), intent(in) :: nvec(ndof_e, nfn) !! normal-displacement rows at facet nodes
        real(dp), intent(in) :: gap(nfn)       !! initial gap at facet nodes
        real(dp), intent(in) :: gamma          !! gamma_N > 0
        integer, intent(in) :: theta           !! -1, 0, 1
        real(dp), intent(in) :: measure        !! facet length (2D), area (3D), 1 in 1D
        integer, intent(in) :: quad            !! QUAD_EXACT or QUAD_GAUSS
        integer, intent(in) :: nq              !! Gauss points (QUAD_GAUSS)
        real(dp), intent(in) :: qs(:, :)       !! (MAX_FN, nq) facet shape values at the Gauss points
        real(dp), intent(in) :: qw(:)          !! Gauss weights (sum 1)
        real(dp), intent(out) :: r(ndof_e)     !! residual contribution
        real(dp), intent(out) :: energy        !! int [P]_-^2 / (2 gamma)
        integer, intent(out) :: active         !! active quadrature points
        real(dp), intent(out), optional :: qa(:, :) !! (ndof_e, >= active) tangent factors:
        real(dp), intent(out), optional :: qb(:, :) !! qa = (w/gamma) P_theta row, qb = dP/du_e
        integer, intent(out), optional :: nterm     !! terms in qa, qb (<= nfn: see above)
        real(dp), intent(out), optional :: ca(:, :) !! (>= nfn, >= nterm) coefficients of qa in Mt
        real(dp), intent(out), optional :: cb(:, :) !! (>= nfn, >= nterm) coefficients of qb in M
        real(dp), intent(out), optional :: rg(:)    !! (>= nfn) coefficients of r in Mt
        real(dp) :: sn, pnode(MAX_FN), rl(MAX_E), rgl(MAX_FN), force
        real(dp) :: qal(MAX_E, MAX_Q), qbl(MAX_E, MAX_Q), cal(MAX_FN, MAX_Q), cbl(MAX_FN, MAX_Q)
        integer :: nt
        sn = dot_product(s, ue)
        pnode = facet_pnode(ndof_e, nfn, ue, sn, nvec, gap, gamma)
        call facet_terms(ndof_e, nfn, pnode, s, nvec, gamma, theta, measure, quad, nq, qs, qw, &
                         present(qa) .or. present(ca) .or. present(rg), &
                         present(nterm) .and. present(qa), rl, energy, active, nt, qal, qbl, &
                         cal, cbl, rgl, force)
        r = rl(1:ndof_e)
        if (present(nterm)) nterm = nt
        if (present(qa)) then
            qa(:, 1:nt) = qal(1:ndof_e, 1:nt)
            qb(:, 1:nt) = qbl(1:ndof_e, 1:nt)
        end if
        if (present(ca)) then
            ca(1:nfn, 1:nt) = cal(1:nfn, 1:nt)
            cb(1:nfn, 1:nt) = cbl(1:nfn, 1:nt)
        end if
        if (present(rg)) rg(1:nfn) = rgl(1:nfn)
    end subroutine nitsche_facet

    !> nitsche_facet given P at the facet's nodes (facet_pnode; the displacement enters
    !> through it alone): contact_eval has formed it to skip inactive facets, and passes
    !> it on rather than having it formed again. Its outputs are fixed-size arrays (the
    !> callers' locals: no array descriptor a call, no optional argument to test at each
    !> point), the terms in their first nterm columns, the rows 1..ndof_e (1..nfn).
    !> With terms false only r, energy and active are formed (nterm = active; qa, qb, ca,
    !> cb, rg are left undefined but for rg = 0); with compress the terms are compressed to
    !> nfn when more than nfn points are active (nitsche_facet with nterm present).
    pure subroutine facet_terms(ndof_e, nfn, pnode, s, nvec, gamma, theta, measure, quad, nq, &
                                qs, qw, terms, compress_ok, r, energy, active, nterm, qa, qb, &
                                ca, cb, rg, force)
        integer, intent(in) :: ndof_e          !! owner cell dofs
        integer, intent(in) :: nfn             !! facet nodes (1 in 1D, 2 in 2D, 3 in 3D)
        real(dp), intent(in) :: pnode(MAX_FN)  !! P at the facet's nodes (the first nfn)
        real(dp), intent(in) :: s(ndof_e)      !! sigma_n row
        real(dp), intent(in) :: nvec(ndof_e, nfn) !! normal-displacement rows at facet nodes
        real(dp), intent(in) :: gamma          !! gamma_N > 0
        integer, intent(in) :: theta           !! -1, 0, 1
        real(dp), intent(in) :: measure        !! facet length (2D), area (3D), 1 in 1D
        integer, intent(in) :: quad            !! QUAD_EXACT or QUAD_GAUSS
        integer, intent(in) :: nq              !! Gauss points (QUAD_GAUSS)
        real(dp), intent(in) :: qs(MAX_FN, *)  !! (MAX_FN, nq) shape values at the Gauss points
        real(dp), intent(in) :: qw(*)          !! (nq) Gauss weights (sum 1)
        logical, intent(in) :: terms           !! form the terms: qa, qb, ca, cb and rg
        logical, intent(in) :: compress_ok     !! (with terms) compress as nitsche_facet
        real(dp), intent(out) :: r(MAX_E)      !! residual contribution (rows 1..ndof_e)
        real(dp), intent(out) :: energy        !! int [P]_-^2 / (2 gamma)
        integer, intent(out) :: active         !! active quadrature points
        integer, intent(out) :: nterm          !! terms in qa, qb (as nitsche_facet's)
        real(dp), intent(out) :: qa(MAX_E, MAX_Q) !! as nitsche_facet's
        real(dp), intent(out) :: qb(MAX_E, MAX_Q) !! as nitsche_facet's
        real(dp), intent(out) :: ca(MAX_FN, MAX_Q) !! as nitsche_facet's
        real(dp), intent(out) :: cb(MAX_FN, MAX_Q) !! as nitsche_facet's
        real(dp), intent(out) :: rg(MAX_FN)    !! as nitsche_facet's
        real(dp), intent(out) :: force         !! int [P]_- (<= 0; the facet's normal force)
        real(dp), parameter :: g2 = 0.5_dp / sqrt(3.0_dp)
        real(dp) :: xs(MAX_Q), ws(MAX_Q), a, b, xi_star
        real(dp) :: shp(MAX_FN, MAX_Q), nsh(MAX_FN), pv, nn(MAX_E), ptheta(MAX_E)
        real(dp) :: g(MAX_FN, MAX_FN), pq(MAX_Q), mt(MAX_E, MAX_FN)
        integer :: np, q, j, i, na
        logical :: compress
        ! (whole fixed-size arrays zeroed: a few stores, no memset call)
        r = 0.0_dp
        energy = 0.0_dp
        force = 0.0_dp
        active = 0
        rg = 0.0_dp
        nterm = 0
        g = 0.0_dp
        if (nfn == 1) then
            np = 1; ws(1) = measure
            shp(:, 1) = facet_shape(1, 0.0_dp)
        else if (quad == QUAD_GAUSS) then
            np = nq; shp(:, 1:nq) = qs(:, 1:nq); ws(1:nq) = measure * qw(1:nq)
        else if (nfn == 3) then
            call triangle_active_rule(pnode(1:3), measure, np, shp, ws)
            if (np == 0) return
        else
            if (pnode(1) >= 0.0_dp .and. pnode(2) >= 0.0_dp) return
            if (pnode(1) < 0.0_dp .and. pnode(2) < 0.0_dp) then
                a = 0.0_dp; b = 1.0_dp
            else
                xi_star = pnode(1) / (pnode(1) - pnode(2))
                if (pnode(1) < 0.0_dp) then
                    a = 0.0_dp; b = xi_star
                else
                    a = xi_star; b = 1.0_dp
                end if
            end if
            np = 2
            xs(1:2) = a + (b - a) * [0.5_dp - g2, 0.5_dp + g2]
            ws(1:2) = 0.5_dp * measure * (b - a)
            do q = 1, 2         ! (facet_shape(2, xs(q)), written here: no call a point)
                shp(1, q) = 1.0_dp - xs(q)
                shp(2, q) = xs(q)
                shp(3, q) = 0.0_dp
            end do
        end if
        ! P at the points first: with more than nfn of them active (and compress_ok)
        ! the tangent is compressed and the points' own qa, qb, ca, cb are not formed
        na = 0
        do q = 1, np
            if (nfn == 3) then     ! (dot_product's sum from 0, written out)
                pq(q) = ((0.0_dp + shp(1, q) * pnode(1)) + shp(2, q) * pnode(2)) &
                        + shp(3, q) * pnode(3)
            else if (nfn == 2) then
                pq(q) = (0.0_dp + shp(1, q) * pnode(1)) + shp(2, q) * pnode(2)
            else
                pq(q) = dot_product(shp(1:nfn, q), pnode(1:nfn))
            end if
            if (pq(q) < 0.0_dp) na = na + 1
        end do
        compress = terms .and. compress_ok .and. na > nfn
        do q = 1, np
            nsh = shp(:, q)
            pv = pq(q)
            if (.not. (pv < 0.0_dp)) cycle
            active = active + 1
            ! nn = nvec nsh column by column (each entry's sum in the order of
            ! dot_product(nvec(j, :), nsh), from 0; the rows of nvec are strided); on a
            ! triangle or a segment the products of an entry written out, in that order
            if (nfn == 3) then
                do j = 1, ndof_e
                    nn(j) = ((0.0_dp + nvec(j, 1) * nsh(1)) + nvec(j, 2) * nsh(2)) &
                            + nvec(j, 3) * nsh(3)
                end do
            else if (nfn == 2) then
                do j = 1, E_2D          ! (ndof_e: a trip count known when compiled)
                    nn(j) = (0.0_dp + nvec(j, 1) * nsh(1)) + nvec(j, 2) * nsh(2)
                end do
            else
                nn = 0.0_dp
                do i = 1, nfn
                    do j = 1, ndof_e
                        nn(j) = nn(j) + nvec(j, i) * nsh(i)
                    end do
                end do
            end if
            if (nfn == 2) then      ! (the same at E_2D = ndof_e rows, a length known)
                ptheta(1:E_2D) = theta * s(1:E_2D) - gamma * nn(1:E_2D)
                r(1:E_2D) = r(1:E_2D) + (ws(q) / gamma) * pv * ptheta(1:E_2D)
            else
                ptheta(1:ndof_e) = theta * s - gamma * nn(1:ndof_e)
                r(1:ndof_e) = r(1:ndof_e) + (ws(q) / gamma) * pv * ptheta(1:ndof_e)
            end if
            ! (rg and g on all MAX_FN rows, a length known when compiled: the rows past
            ! nfn, shape values 0, are never read)
            if (terms) rg = rg + ((ws(q) / gamma) * pv) * nsh
            energy = energy + (0.5_dp * ws(q) / gamma) * pv**2
            force = force + ws(q) * pv
            if (compress) then
                do j = 1, nfn
                    g(:, j) = g(:, j) + ((ws(q) / gamma) * nsh(j)) * nsh
                end do
                cycle
            end if
            if (terms .and. nfn == 2) then
                qa(1:E_2D, active) = (ws(q) / gamma) * ptheta(1:E_2D)
                qb(1:E_2D, active) = s(1:E_2D) - gamma * nn(1:E_2D)
            else if (terms) then
                qa(1:ndof_e, active) = (ws(q) / gamma) * ptheta(1:ndof_e)
                qb(1:ndof_e, active) = s - gamma * nn(1:ndof_e)
            end if
            if (terms) then
                ! (whole columns: shp is defined on all MAX_FN rows; rows 1..nfn are read)
                ca(:, active) = (ws(q) / gamma) * nsh
                cb(:, active) = nsh
            end if
        end do
        nterm = active
        if (.not. compress) return
        nterm = nfn
        do i = 1, nfn      ! the columns of Mt, formed once
            mt(1:ndof_e, i) = theta * s - gamma * nvec(:, i)
        end do
        do j = 1, nfn
            qa(:, j) = 0.0_dp
            do i = 1, nfn
                qa(1:ndof_e, j) = qa(1:ndof_e, j) + g(i, j) * mt(1:ndof_e, i)
            end do
            qb(1:ndof_e, j) = s - gamma * nvec(:, j)
            ca(:, j) = g(:, j)
            cb(:, j) = 0.0_dp
            cb(j, j) = 1.0_dp
        end do
    end subroutine facet_terms

    !> P = P_1(u) + gamma g at the facet's nodes (sn = sigma_n(u) = s . ue): P is linear
    !> on the facet, so no point of any rule is active where all of them are >= 0.
    pure function facet_pnode(ndof_e, nfn, ue, sn, nvec, gap, gamma) result(pnode)
        integer, intent(in) :: ndof_e          !! owner cell dofs
        integer, intent(in) :: nfn             !! facet nodes
        real(dp), intent(in) :: ue(ndof_e)     !! owner cell displacement
        real(dp), intent(in) :: sn             !! sigma_n(u)
        real(dp), intent(in) :: nvec(ndof_e, nfn) !! normal-displacement rows at facet nodes
        real(dp), intent(in) :: gap(nfn)       !! initial gap at facet nodes
        real(dp), intent(in) :: gamma          !! gamma_N > 0
        real(dp) :: pnode(MAX_FN)              !! the first nfn entries (the rest 0)
        integer :: j
        pnode = 0.0_dp
        do j = 1, nfn
            pnode(j) = sn - gamma * (dot_product(ue, nvec(:, j)) - gap(j))
        end do
    end function facet_pnode

    !> The exact rule of a triangle facet for the integrands of nitsche_facet: the part
    !> {P < 0} of the triangle (P linear, nodal values pnode) is a triangle or a
    !> quadrilateral (two triangles) cut off by the zero line of P; each piece gets the
    !> symmetric 3-point rule of degree 2 (points inside the piece, where P < 0).
    !> (Explicit-shape outputs and the vertices a constant: nothing to set up a call.)
    pure subroutine triangle_active_rule(pnode, measure, np, shp, ws)
        real(dp), intent(in) :: pnode(3)          !! P at the facet's nodes
        real(dp), intent(in) :: measure           !! facet area
        integer, intent(out) :: np                !! points (0, 3 or 6)
        real(dp), intent(out) :: shp(MAX_FN, *)   !! (MAX_FN, >= 6) shape values at the points
        real(dp), intent(out) :: ws(*)            !! (>= 6) weights (area x rule weight)
        !> the triangle's vertices in barycentric coordinates
        real(dp), parameter :: e(3, 3) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, &
                                                  0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], [3, 3])
        real(dp) :: z1(3), z2(3)
        integer :: neg, i, j, k
        neg = count(pnode < 0.0_dp)
        np = 0
        select case (neg)
        case (3)
            call add_piece(e(:, 1), e(:, 2), e(:, 3), measure, np, shp, ws)
        case (1, 2)
            ! i: the node alone on its side of the zero line; j, k: the other two
            if (neg == 1) then
                i = findloc(pnode < 0.0_dp, .true., dim=1)
            else
                i = findloc(pnode < 0.0_dp, .false., dim=1)
            end if
            j = modulo(i, 3) + 1
            k = modulo(j, 3) + 1
            z1 = e(:, i) + pnode(i) / (pnode(i) - pnode(j)) * (e(:, j) - e(:, i))   ! zero on edge i-j
            z2 = e(:, i) + pnode(i) / (pnode(i) - pnode(k)) * (e(:, k) - e(:, i))   ! zero on edge i-k
            if (neg == 1) then
                call add_piece(e(:, i), z1, z2, measure, np, shp, ws)
            else
                call add_piece(e(:, j), e(:, k), z2, measure, np, shp, ws)
                call add_piece(e(:, j), z2, z1, measure, np, shp, ws)
            end if
        end select
    end subroutine triangle_active_rule

    !> Append the 3-point rule of degree 2 on the sub-triangle with barycentric
    !> vertices v1, v2, v3 of a facet of area `measure`.
    pure subroutine add_piece(v1, v2, v3, measure, np, shp, ws)
        real(dp), intent(in) :: v1(3), v2(3), v3(3)   !! vertices (barycentric)
        real(dp), intent(in) :: measure               !! facet area
        integer, intent(inout) :: np                  !! points so far
        real(dp), intent(inout) :: shp(MAX_FN, *)     !! shape values at the points
        real(dp), intent(inout) :: ws(*)              !! weights
        real(dp), parameter :: P_MAJ = 2.0_dp / 3.0_dp, P_MIN = 1.0_dp / 6.0_dp
        real(dp) :: frac
        frac = abs((v2(2) - v1(2)) * (v3(3) - v1(3)) - (v2(3) - v1(3)) * (v3(2) - v1(2)))
        shp(:, np + 1) = P_MAJ * v1 + P_MIN * v2 + P_MIN * v3
        shp(:, np + 2) = P_MIN * v1 + P_MAJ * v2 + P_MIN * v3
        shp(:, np + 3) = P_MIN * v1 + P_MIN * v2 + P_MAJ * v3
        ws(np + 1:np + 3) = measure * frac / 3.0_dp
        np = np + 3
    end subroutine add_piece

    !> Nitsche contact pressure [P_1(u) + gamma g]_- at a point of one facet, given by
    !> the facet's shape values there.
    pure function facet_pressure(ndof_e, nfn, ue, s, nvec, gap, gamma, nsh) result(p)
        integer, intent(in) :: ndof_e          !! owner cell dofs
        integer, intent(in) :: nfn             !! facet nodes
        real(dp), intent(in) :: ue(ndof_e)     !! owner cell displacement
        real(dp), intent(in) :: s(ndof_e)      !! sigma_n row
        real(dp), intent(in) :: nvec(ndof_e, nfn) !! normal rows
        real(dp), intent(in) :: gap(nfn)       !! gap at facet nodes
        real(dp), intent(in) :: gamma          !! gamma_N
        real(dp), intent(in) :: nsh(:)         !! (>= nfn) facet shape values at the point
        real(dp) :: p
        real(dp) :: un(MAX_FN)
        integer :: j
        do j = 1, nfn
            un(j) = dot_product(ue, nvec(:, j)) - gap(j)
        end do
        p = dot_product(s, ue) - gamma * dot_product(nsh(1:nfn), un(1:nfn))
        p = min(p, 0.0_dp)
    end function facet_pressure

    !> Set up the contact facets `facets` (indices into msh%facets): owner cells,
    !> sigma_n rows, normal rows, gaps, gamma_N = gamma0 / diameter(owner).
    !> Contact data of the facets: owner cells, sigma_n rows s, normal rows, gaps, gamma_N.
    !> With penalty, s = 0 and theta = 0 (penalty contact, see the module header).
    pure subroutine contact_init(ct, msh, facets, dof, young, lambda, mu, normal, point, gamma0, &
                            theta, quad, nq, stat, errmsg, penalty)
        type(contact_t), intent(out) :: ct                  !! contact data
        type(mesh_t), intent(in) :: msh                     !! mesh
        integer, intent(in) :: facets(:)                    !! contact facets
        integer, intent(in) :: dof(:, :)                    !! (dim, n_nodes) free dof or 0
        real(dp), intent(in) :: young                       !! E (1D)
        real(dp), intent(in) :: lambda                      !! Lame lambda (2D)
        real(dp), intent(in) :: mu                          !! Lame mu (2D)
        real(dp), intent(in) :: normal(:)                   !! (dim) unit outward normal (into obstacle)
        real(dp), intent(in) :: point(:)                    !! (dim) point of the obstacle plane
        real(dp), intent(in) :: gamma0                      !! gamma0 > 0
        integer, intent(in) :: theta                        !! -1, 0, 1
        integer, intent(in) :: quad                         !! QUAD_EXACT or QUAD_GAUSS
        integer, intent(in) :: nq                           !! Gauss points
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        logical, intent(in), optional :: penalty            !! penalty contact (default .false.)
        integer :: dim, nf, f, c, j, a, kk, nloc, ndof_e, i, nown
        integer, allocatable :: first(:), adj(:)
        real(dp) :: grad(msh%dim, msh%dim + 1), xe(msh%dim, msh%dim + 1), gn, xq(6), e1(3), e2(3)
        stat = STAT_OK
        dim = msh%dim
        nf = size(facets)
        ndof_e = dim * (dim + 1)
        ct%dim = dim; ct%n_facets = nf; ct%ndof_e = ndof_e; ct%nfn = dim
        ct%theta = theta; ct%quad = quad; ct%nq = nq
        if (quad == QUAD_GAUSS .and. dim == 3) then
            if (.not. any(nq == [1, 3, 6, 7])) then
                call raise(stat, errmsg, STAT_BAD_INPUT, 'quad_points must be 1, 3, 6 or 7 '// &
                           'on triangle facets (3D)')
                return
            end if
            call triangle_rule(nq, ct%qs, ct%qw)
        else if (quad == QUAD_GAUSS) then
            call gauss_rule(nq, xq, ct%qw(1:6))
            do j = 1, nq
                ct%qs(:, j) = facet_shape(2, xq(j))
            end do
        end if
        allocate (ct%cell(nf), ct%nodes(dim, nf), ct%dofs(ndof_e, nf), ct%s(ndof_e, nf), &
                  ct%nvec(ndof_e, dim, nf), ct%gap(dim, nf), ct%gamma(nf), ct%measure(nf), &
                  ct%cloc(ndof_e, nf))
        call node_cells(msh, first, adj)
        do f = 1, nf
            ct%nodes(:, f) = msh%facets(:, facets(f))
            ! the cells that have the facet as a face: exactly one (its owner); a facet of
            ! two cells lies inside the body, where it cannot touch the obstacle
            ct%cell(f) = 0
            nown = 0
            do i = first(ct%nodes(1, f)), first(ct%nodes(1, f) + 1) - 1
                c = adj(i)
                if (all([(any(msh%cells(:, c) == ct%nodes(j, f)), j=1, dim)])) then
                    if (nown == 0) ct%cell(f) = c
                    nown = nown + 1
                end if
            end do
            if (nown == 0) then
                call raise(stat, errmsg, STAT_BAD_INPUT, 'a contact facet belongs to no cell')
                return
            else if (nown > 1) then
                call raise(stat, errmsg, STAT_BAD_INPUT, 'a contact facet lies inside '// &
                           'the body (it is a face of two cells): the contact boundary '// &
                           'must be on the body''s boundary')
                return
            end if
            c = ct%cell(f)
            xe = msh%x(:, msh%cells(:, c))
            call p1_gradients(dim, xe, grad)
            ct%gamma(f) = gamma0 / simplex_diameter(dim, xe)
            if (dim == 1) then
                ct%measure(f) = 1.0_dp
            else if (dim == 3) then
                e1 = msh%x(:, ct%nodes(2, f)) - msh%x(:, ct%nodes(1, f))
                e2 = msh%x(:, ct%nodes(3, f)) - msh%x(:, ct%nodes(1, f))
                ct%measure(f) = 0.5_dp * euclid_length([e1(2) * e2(3) - e1(3) * e2(2), &
                                                        e1(3) * e2(1) - e1(1) * e2(3), &
                                                        e1(1) * e2(2) - e1(2) * e2(1)])
            else
                ct%measure(f) = euclid_length(msh%x(:, ct%nodes(2, f)) &
                                              - msh%x(:, ct%nodes(1, f)))
            end if
            ct%nvec(:, :, f) = 0.0_dp
            do a = 1, dim + 1
                gn = dot_product(normal(1:dim), grad(:, a))
                do kk = 1, dim
                    i = dim * (a - 1) + kk
                    ct%dofs(i, f) = dof(kk, msh%cells(a, c))
                    if (dim == 1) then
                        ct%s(i, f) = young * grad(1, a)
                    else
                        ct%s(i, f) = lambda * grad(kk, a) + 2.0_dp * mu * gn * normal(kk)
                    end if
                end do
            end do
            do j = 1, dim
                nloc = 0
                do a = 1, dim + 1
                    if (msh%cells(a, c) == ct%nodes(j, f)) nloc = a
                end do
                ct%nvec(dim * (nloc - 1) + 1:dim * nloc, j, f) = normal(1:dim)
                ct%gap(j, f) = dot_product(point(1:dim) - msh%x(:, ct%nodes(j, f)), normal(1:dim))
            end do
        end do
        call number_contact_dofs(ct, maxval([0, dof]))
        if (present(penalty)) then
            if (penalty) then
                ct%s = 0.0_dp
                ct%theta = 0
            end if
        end if
    end subroutine contact_init

    !> Node -> cells adjacency in CSR form: the cells of node i are
    !> adj(first(i):first(i + 1) - 1), in increasing order.
    pure subroutine node_cells(msh, first, adj)
        type(mesh_t), intent(in) :: msh                     !! mesh
        integer, allocatable, intent(out) :: first(:)       !! (n_nodes + 1) row starts
        integer, allocatable, intent(out) :: adj(:)         !! cells, node by node
        integer, allocatable :: next(:)
        integer :: c, a, i
        allocate (first(msh%n_nodes + 1), adj(msh%n_cells * (msh%dim + 1)))
        first = 0
        do c = 1, msh%n_cells
            first(msh%cells(:, c) + 1) = first(msh%cells(:, c) + 1) + 1
        end do
        first(1) = 1
        do i = 2, msh%n_nodes + 1
            first(i) = first(i) + first(i - 1)
        end do
        next = first
        do c = 1, msh%n_cells
            do a = 1, msh%dim + 1
                adj(next(msh%cells(a, c))) = c
                next(msh%cells(a, c)) = next(msh%cells(a, c)) + 1
            end do
        end do
    end subroutine node_cells

    !> The distinct free dofs of the contact facets' owner cells, numbered in order of
    !> first appearance (ct%m, ct%cdofs), and each facet dof's place among them (ct%cloc).
    pure subroutine number_contact_dofs(ct, n_dofs)
        type(contact_t), intent(inout) :: ct                !! contact data (dofs set)
        integer, intent(in) :: n_dofs                       !! number of free dofs
        integer, allocatable :: mark(:)
        integer :: f, i, j, cnt
        allocate (mark(n_dofs))
        mark = 0
        cnt = 0
        do f = 1, ct%n_facets
            do i = 1, ct%ndof_e
                j = ct%dofs(i, f)
                if (j == 0) cycle
                if (mark(j) == 0) then
                    cnt = cnt + 1
                    mark(j) = cnt
                end if
            end do
        end do
        ct%m = cnt
        allocate (ct%cdofs(cnt))
        do j = 1, size(mark)
            if (mark(j) > 0) ct%cdofs(mark(j)) = j
        end do
        do f = 1, ct%n_facets
            do i = 1, ct%ndof_e
                ct%cloc(i, f) = 0
                if (ct%dofs(i, f) > 0) ct%cloc(i, f) = mark(ct%dofs(i, f))
            end do
        end do
    end subroutine number_contact_dofs

    !> Add the nonlinear contact part of B(u) to r (free dofs); count active points;
    !> e_pen = int [P]_-^2/(2 gamma); e_theta = sum theta |F| sigma_n^2/(2 gamma).
    !> With ua present, also return the contact tangent in low-rank form on the
    !> contact-cell dofs (cdofs): D = sum_q ua(:, q) vb(:, q)^T, q = 1..rank, each pair
    !> supported on the cdofs qloc(:, q) (0 = constrained dof, value 0); a facet gives one
    !> term an active point, or nfn terms when more points are active (nitsche_facet's
    !> nterm: rank <= 3 a facet in 3D, the Woodbury system of the implicit schemes sized
    !> by it). With tfac present (and ua), also each term's facet and its coefficients
    !> tca, tcb in the facet's Mt and M (nitsche_facet's ca, cb), and with rg present (and
    !> tfac) each facet's residual coefficients in its Mt (nitsche_facet's rg; zero on a
    !> facet without active points): the contact part is sum_f Mt_f rg(:, f).
    !> With f_n present, also the total normal contact force f_n = int_GammaC [P]_- ds
    !> (<= 0, the sign of the pressure; per unit thickness in 2D) on the active facets'
    !> rule: against the rigid translation along n (sigma_n = 0, v_n = 1) the contact
    !> part added to r is -f_n for any theta (r . t = -sum_q w_q [P]_q to round-off).
    pure subroutine contact_eval(ct, u, r, active, e_pen, e_theta, rank, ua, vb, qloc, tfac, tca, &
                            tcb, rg, f_n)
        type(contact_t), intent(in) :: ct                   !! contact data
        real(dp), intent(in) :: u(:)                        !! free-dof displacement
        real(dp), intent(inout), contiguous :: r(:)         !! residual (added to)
        integer, intent(out) :: active                      !! active quadrature points
        real(dp), intent(out) :: e_pen                      !! penalty-like energy
        real(dp), intent(out) :: e_theta                    !! theta sigma_n^2 energy term
        integer, intent(out), optional :: rank              !! number of rank-one terms
        ! (contiguous: the columns are written with unit stride)
        real(dp), intent(inout), optional, contiguous :: ua(:, :)   !! (ndof_e, >= rank) left factors
        real(dp), intent(inout), optional, contiguous :: vb(:, :)   !! (ndof_e, >= rank) right factors
        integer, intent(inout), optional, contiguous :: qloc(:, :)  !! (ndof_e, >= rank) their cdofs
        integer, intent(inout), optional :: tfac(:)                 !! (>= rank) each term's facet
        real(dp), intent(inout), optional, contiguous :: tca(:, :)  !! (nfn, >= rank) its coefficients in Mt
        real(dp), intent(inout), optional, contiguous :: tcb(:, :)  !! (nfn, >= rank) and in M
        real(dp), intent(inout), optional, contiguous :: rg(:, :)   !! (nfn, n_facets) residual in Mt
        real(dp), intent(out), optional :: f_n                      !! int [P]_- ds (<= 0)
        ! fixed sizes: no heap array a call; the facet kernel writes its terms here and
        ! they are copied to the outputs present (one call of the kernel for every set of
        ! outputs, with no array descriptor or optional argument to pass)
        real(dp) :: rf(MAX_E), ef, sn, pnode(MAX_FN), rgf(MAX_FN), ff, fsum
        real(dp) :: qa(MAX_E, MAX_Q), qb(MAX_E, MAX_Q), ca(MAX_FN, MAX_Q), cb(MAX_FN, MAX_Q)
        integer :: f, i, af, nr, nt, t, ne, nfn
        logical :: terms
        active = 0
        e_pen = 0.0_dp
        e_theta = 0.0_dp
        fsum = 0.0_dp
        nr = 0
        ne = ct%ndof_e
        nfn = ct%nfn
        terms = present(ua)
        do f = 1, ct%n_facets
            call facet_sn_pnode(ct, f, u, sn, pnode)
            e_theta = e_theta + facet_e_theta(ct, f, sn)
            ! a facet with P >= 0 at its nodes has no active point (nothing to add)
            if (all(pnode(1:nfn) >= 0.0_dp)) then
                if (present(rg)) rg(1:nfn, f) = 0.0_dp
                cycle
            end if
            call facet_terms(ne, nfn, pnode, ct%s(:, f), ct%nvec(:, :, f), ct%gamma(f), &
                             ct%theta, ct%measure(f), ct%quad, ct%nq, ct%qs, ct%qw, terms, &
                             terms, rf, ef, af, nt, qa, qb, ca, cb, rgf, ff)
            if (present(rg)) then
                do i = 1, nfn
                    rg(i, f) = rgf(i)
                end do
            end if
            if (terms) then
                do t = 1, nt
                    if (ne == MAX_E) then   ! (3D: copies of a length known when compiled)
                        ua(1:MAX_E, nr + t) = qa(:, t)
                        vb(1:MAX_E, nr + t) = qb(:, t)
                        qloc(1:MAX_E, nr + t) = ct%cloc(1:MAX_E, f)
                    else if (ne == E_2D) then   ! (2D: the same, not a memcpy call each,
                        ! and below for tca, tcb)
                        ua(1:E_2D, nr + t) = qa(1:E_2D, t)
                        vb(1:E_2D, nr + t) = qb(1:E_2D, t)
                        qloc(1:E_2D, nr + t) = ct%cloc(1:E_2D, f)
                    else
                        ua(1:ne, nr + t) = qa(1:ne, t)
                        vb(1:ne, nr + t) = qb(1:ne, t)
                        qloc(1:ne, nr + t) = ct%cloc(1:ne, f)
                    end if
                    if (present(tfac)) tfac(nr + t) = f
                    if (.not. present(tca)) cycle
                    if (nfn == MAX_FN) then
                        tca(1:MAX_FN, nr + t) = ca(:, t)
                        tcb(1:MAX_FN, nr + t) = cb(:, t)
                    else if (nfn == 2) then
                        tca(1:2, nr + t) = ca(1:2, t)
                        tcb(1:2, nr + t) = cb(1:2, t)
                    else
                        tca(1:nfn, nr + t) = ca(1:nfn, t)
                        tcb(1:nfn, nr + t) = cb(1:nfn, t)
                    end if
                end do
                nr = nr + nt
            end if
            if (af == 0) cycle
            active = active + af
            e_pen = e_pen + ef
            fsum = fsum + ff
            call cell_add(ne, ct%dofs(:, f), rf, size(r), r)
        end do
        if (present(rank)) rank = nr
        if (present(f_n)) f_n = fsum
    end subroutine contact_eval

    !> r(dofs(i)) <- r(dofs(i)) + rf(i) over the cell's free dofs (dofs(i) > 0), in their
    !> order (explicit shapes: a tight loop).
    pure subroutine cell_add(ne, dofs, rf, n, r)
        integer, intent(in) :: ne                           !! cell dofs
        integer, intent(in) :: dofs(ne)                     !! their free dofs (0: constrained)
        real(dp), intent(in) :: rf(ne)                      !! the cell's values
        integer, intent(in) :: n                            !! free dofs
        real(dp), intent(inout) :: r(n)                     !! the vector (added to)
        integer :: i, d
        do i = 1, ne
            d = dofs(i)
            if (d > 0) r(d) = r(d) + rf(i)
        end do
    end subroutine cell_add

    !> Whether no contact point can be active at u: P finite and >= 0 at the nodes of
    !> every facet (P is linear on a facet; >= 0 is contact_eval's test to skip a facet).
    !> Then contact_eval adds nothing to r and returns active = 0, e_pen = 0, rank = 0,
    !> rg = 0, and the e_theta returned here (the same sums in the same order); and
    !> facet_pressure at a facet's node is that node's P (its other shape values are 0,
    !> the other terms +-0 as they are finite), so [P]_- = 0 there to the bit. Stops at
    !> the first facet that fails the test (e_theta is then partial).
    pure subroutine contact_clear(ct, u, clear, e_theta)
        type(contact_t), intent(in) :: ct      !! contact data
        real(dp), intent(in) :: u(:)           !! free-dof displacement
        logical, intent(out) :: clear          !! P finite and >= 0 at every facet's nodes
        real(dp), intent(out) :: e_theta       !! theta sigma_n^2 energy term (when clear)
        real(dp) :: sn, pnode(MAX_FN)
        integer :: f, j
        clear = .false.
        e_theta = 0.0_dp
        do f = 1, ct%n_facets
            call facet_sn_pnode(ct, f, u, sn, pnode)
            e_theta = e_theta + facet_e_theta(ct, f, sn)
            do j = 1, ct%nfn
                if (.not. (pnode(j) >= 0.0_dp .and. pnode(j) <= huge(1.0_dp))) return
            end do
        end do
        clear = .true.
    end subroutine contact_clear

    !> Facet f's term of the theta sigma_n^2 energy, theta |F| sn^2 / (2 gamma): the one
    !> expression contact_eval and contact_clear sum (so their e_theta agree to the bit).
    pure real(dp) function facet_e_theta(ct, f, sn)
        type(contact_t), intent(in) :: ct      !! contact data
        integer, intent(in) :: f               !! facet
        real(dp), intent(in) :: sn             !! sigma_n(u) on it
        facet_e_theta = ct%theta * ct%measure(f) * sn**2 / (2.0_dp * ct%gamma(f))
    end function facet_e_theta

    !> sigma_n(u) and P at the nodes of facet f (facet_pnode) from the free-dof vector u,
    !> the owner cell's values gathered (0 at constrained dofs).
    pure subroutine facet_sn_pnode(ct, f, u, sn, pnode)
        type(contact_t), intent(in) :: ct      !! contact data
        integer, intent(in) :: f               !! facet
        real(dp), intent(in) :: u(:)           !! free-dof displacement
        real(dp), intent(out) :: sn            !! sigma_n(u) = s . ue
        real(dp), intent(out) :: pnode(MAX_FN) !! P at the facet's nodes (the rest 0)
        real(dp) :: ue(MAX_E)                  ! fixed size: no heap array a call
        real(dp) :: x, d1, d2, d3
        integer :: i, d
        if (ct%nfn == 3) then
            ! a triangle facet: the four sums in one pass over the dofs, each in their
            ! order from 0 as dot_product's in the general case (the same values; ue's
            ! x and nvec's entry multiplied in either order: the same product)
            sn = 0.0_dp; d1 = 0.0_dp; d2 = 0.0_dp; d3 = 0.0_dp
            do i = 1, ct%ndof_e
                d = ct%dofs(i, f)
                x = merge(u(max(d, 1)), 0.0_dp, d > 0)
                sn = sn + ct%s(i, f) * x
                d1 = d1 + x * ct%nvec(i, 1, f)
                d2 = d2 + x * ct%nvec(i, 2, f)
                d3 = d3 + x * ct%nvec(i, 3, f)
            end do
            pnode(1) = sn - ct%gamma(f) * (d1 - ct%gap(1, f))
            pnode(2) = sn - ct%gamma(f) * (d2 - ct%gap(2, f))
            pnode(3) = sn - ct%gamma(f) * (d3 - ct%gap(3, f))
            return
        end if
        if (ct%nfn == 2) then
            ! a segment facet: the three sums in one pass, as the triangle's (the rest of
            ! pnode 0, as facet_pnode's), over the 2D cell's E_2D dofs (a trip count known
            ! when compiled)
            sn = 0.0_dp; d1 = 0.0_dp; d2 = 0.0_dp
            do i = 1, E_2D
                d = ct%dofs(i, f)
                x = merge(u(max(d, 1)), 0.0_dp, d > 0)
                sn = sn + ct%s(i, f) * x
                d1 = d1 + x * ct%nvec(i, 1, f)
                d2 = d2 + x * ct%nvec(i, 2, f)
            end do
            pnode(1) = sn - ct%gamma(f) * (d1 - ct%gap(1, f))
            pnode(2) = sn - ct%gamma(f) * (d2 - ct%gap(2, f))
            pnode(3) = 0.0_dp
            return
        end if
        do i = 1, ct%ndof_e       ! (a select, not a branch and a zeroing pass: no arithmetic)
            d = ct%dofs(i, f)
            ue(i) = merge(u(max(d, 1)), 0.0_dp, d > 0)
        end do
        sn = dot_product(ct%s(:, f), ue(1:ct%ndof_e))
        pnode = facet_pnode(ct%ndof_e, ct%nfn, ue, sn, ct%nvec(:, :, f), ct%gap(:, f), &
                            ct%gamma(f))
    end subroutine facet_sn_pnode

    !> Largest rank contact_eval can return: active points per facet times facets.
    pure function contact_max_rank(ct) result(rmax)
        type(contact_t), intent(in) :: ct   !! contact data
        integer :: rmax
        if (ct%nfn == 1) then
            rmax = ct%n_facets
        else if (ct%quad == QUAD_GAUSS) then
            rmax = ct%n_facets * max(ct%nq, 1)
        else
            rmax = ct%n_facets * merge(6, 2, ct%nfn == 3)   ! exact: two 3-point pieces on a triangle
        end if
    end function contact_max_rank

    !> Gauss-Legendre rule with n (1..6) points on [0, 1].
    pure subroutine gauss_rule(n, x, w)
        integer, intent(in) :: n          !! points
        real(dp), intent(out) :: x(6)     !! points on [0, 1]
        real(dp), intent(out) :: w(6)     !! weights (sum 1)
        real(dp) :: t(6), c(6)
        t = 0.0_dp; c = 0.0_dp
        select case (n)
        case (1)
            t(1) = 0.0_dp; c(1) = 2.0_dp
        case (2)
            t(1:2) = [-1.0_dp, 1.0_dp] / sqrt(3.0_dp); c(1:2) = 1.0_dp
        case (3)
            t(1:3) = [-sqrt(0.6_dp), 0.0_dp, sqrt(0.6_dp)]
            c(1:3) = [5.0_dp, 8.0_dp, 5.0_dp] / 9.0_dp
        case (4)
            t(1:4) = [-0.8611363115940526_dp, -0.3399810435848563_dp, &
                      0.3399810435848563_dp, 0.8611363115940526_dp]
            c(1:4) = [0.3478548451374538_dp, 0.6521451548625461_dp, &
                      0.6521451548625461_dp, 0.3478548451374538_dp]
        case (5)
            t(1:5) = [-0.9061798459386640_dp, -0.5384693101056831_dp, 0.0_dp, &
                      0.5384693101056831_dp, 0.9061798459386640_dp]
            c(1:5) = [0.2369268850561891_dp, 0.4786286704993665_dp, 0.5688888888888889_dp, &
                      0.4786286704993665_dp, 0.2369268850561891_dp]
        case default
            t = [-0.9324695142031521_dp, -0.6612093864662645_dp, -0.2386191860831969_dp, &
                 0.2386191860831969_dp, 0.6612093864662645_dp, 0.9324695142031521_dp]
            c = [0.1713244923791704_dp, 0.3607615730481386_dp, 0.4679139345726910_dp, &
                 0.4679139345726910_dp, 0.3607615730481386_dp, 0.1713244923791704_dp]
        end select
        x = 0.5_dp * (t + 1.0_dp)
        w = 0.5_dp * c
        if (n < 6) then
            x(n + 1:) = 0.0_dp; w(n + 1:) = 0.0_dp
        end if
    end subroutine gauss_rule

    !> Symmetric rules on a triangle with n = 1, 3, 6, 7 points (degree 1, 2, 4, 5; the
    !> 7-point one is Radon's, GetFEM's IM_TRIANGLE(5)): barycentric coordinates of the
    !> points and weights summing to 1.
    pure subroutine triangle_rule(n, bary, w)
        integer, intent(in) :: n              !! 1, 3, 6 or 7
        real(dp), intent(out) :: bary(:, :)   !! (3, >= n) barycentric coordinates
        real(dp), intent(out) :: w(:)         !! (>= n) weights
        real(dp) :: a, b, s15
        bary = 0.0_dp
        w = 0.0_dp
        select case (n)
        case (1)
            bary(:, 1) = 1.0_dp / 3.0_dp
            w(1) = 1.0_dp
        case (3)
            call orbit(bary, w, 1, 1.0_dp / 6.0_dp, 1.0_dp / 3.0_dp)
        case (6)
            call orbit(bary, w, 1, 0.445948490915964886_dp, 0.223381589678011466_dp)
            call orbit(bary, w, 4, 0.091576213509770743_dp, 0.109951743655321868_dp)
        case (7)
            s15 = sqrt(15.0_dp)
            bary(:, 1) = 1.0_dp / 3.0_dp
            w(1) = 9.0_dp / 40.0_dp
            a = (6.0_dp - s15) / 21.0_dp
            b = (6.0_dp + s15) / 21.0_dp
            call orbit(bary, w, 2, a, (155.0_dp - s15) / 1200.0_dp)
            call orbit(bary, w, 5, b, (155.0_dp + s15) / 1200.0_dp)
        end select
    end subroutine triangle_rule

    !> The point (1 - 2c, c, c) and its rotations, weight wc each, as points k..k+2.
    pure subroutine orbit(bary, w, k, c, wc)
        real(dp), intent(inout) :: bary(:, :)   !! barycentric coordinates
        real(dp), intent(inout) :: w(:)         !! weights
        integer, intent(in) :: k                !! first point
        real(dp), intent(in) :: c               !! the repeated coordinate
        real(dp), intent(in) :: wc              !! weight
        bary(:, k) = [1.0_dp - 2.0_dp * c, c, c]
        bary(:, k + 1) = [c, 1.0_dp - 2.0_dp * c, c]
        bary(:, k + 2) = [c, c, 1.0_dp - 2.0_dp * c]
        w(k:k + 2) = wc
    end subroutine orbit
end module nitsche_contact
