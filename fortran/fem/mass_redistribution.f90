!> The redistributed ("modified") mass matrix of Khenous, Laborde and Renard (2008),
!> `&scheme mass = 'redistributed'`: no inertia on the contact-boundary nodes, the mass
!> moved to interior neighbours so that the total mass and the first moments are kept.
!>
!> On the free-dof matrix M (consistent P1 mass) and for each displacement component k:
!> - every entry M_ij with i or j a dof of a contact node is removed (set to 0); the removed
!>   mass is dT = sum M_ij and its first moment dX = sum M_ij (x_i + x_j)/2 (d values;
!>   x_i the position of dof i's node; for a symmetric M, sum_ij M_ij x_j = sum_ij M_ij
!>   (x_i + x_j)/2);
!> - the receiving set P is the pattern entries (i, j) between dofs of component k of the
!>   region nodes: the non-contact nodes within `layers` cells of the contact nodes
!>   (the model uses four: the removed mass has its centroid between the contact nodes
!>   and the first interior layer, so matching the first moment needs some negative
!>   correction further in; with two layers it is concentrated enough to make M'
!>   indefinite on the 1D bar, from three layers on M' stays positive definite, and with
!>   four its smallest eigenvalue is within 4 % of the consistent mass's);
!> - the correction E on P of least Frobenius norm with sum_P E_ij = dT and
!>   sum_P E_ij (x_i + x_j)/2 = dX is E_ij = phi_ij . lambda, phi_ij = (1, (x_i + x_j)/2),
!>   G lambda = (dT, dX), G = sum_P phi_ij phi_ij^T ((d+1) x (d+1), symmetric E).
!> So M' keeps 1.M.1 and 1.M.x per component exactly, is symmetric, and has zero rows and
!> columns on the contact dofs. Whether M' stays positive definite on the other dofs
!> depends on the cell layers behind the contact nodes (a short body, or contact on two
!> opposite sides, can leave too few): a run checks it with one LDL^T factorization
!> when it starts, and refuses the scene when it is not (model's model_mass_definite).
module mass_redistribution
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, raise
    use sparse, only: csc_t
    use dense_lu, only: dense_lu_factor, dense_lu_solve
    implicit none
    private

    public :: mass_region, mass_redistribute

contains

    !> Nodes within `layers` cells of the contact nodes, contact nodes excluded.
    pure subroutine mass_region(cells, contact_node, layers, region)
        integer, intent(in) :: cells(:, :)           !! (nodes per cell, n_cells) connectivity
        logical, intent(in) :: contact_node(:)       !! (n_nodes) nodes of Gamma_C
        integer, intent(in) :: layers                !! cell layers (>= 1)
        logical, intent(out) :: region(:)            !! (n_nodes) receiving nodes
        logical :: reached(size(contact_node)), next(size(contact_node))
        integer :: layer, c
        reached = contact_node
        do layer = 1, layers
            next = reached
            do c = 1, size(cells, 2)
                if (any(reached(cells(:, c)))) next(cells(:, c)) = .true.
            end do
            reached = next
        end do
        region = reached .and. .not. contact_node
    end subroutine mass_region

    !> Remove the contact dofs' rows and columns of M and spread their mass over the
    !> region (see the module header). massless marks the dofs with no inertia.
    subroutine mass_redistribute(mass, dof_node, dof_comp, x, contact_node, region, massless, &
                                 stat, errmsg)
        type(csc_t), intent(inout) :: mass                  !! M on the free dofs (symmetric)
        integer, intent(in) :: dof_node(:)                  !! (n_dofs) node of each dof
        integer, intent(in) :: dof_comp(:)                  !! (n_dofs) component of each dof
        real(dp), intent(in) :: x(:, :)                     !! (dim, n_nodes) coordinates
        logical, intent(in) :: contact_node(:)              !! (n_nodes) nodes of Gamma_C
        logical, intent(in) :: region(:)                    !! (n_nodes) receiving nodes
        logical, intent(out) :: massless(:)                 !! (n_dofs) dofs of contact nodes
        integer, intent(out) :: stat                        !! STAT_OK, STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: dim, k, j, p, i, info, pass, piv(size(x, 1) + 1)
        real(dp) :: g(size(x, 1) + 1, size(x, 1) + 1), rhs(size(x, 1) + 1), phi(size(x, 1) + 1)
        real(dp) :: ell
        logical :: removed, receiving
        stat = STAT_OK
        dim = size(x, 1)
        massless = contact_node(dof_node)
        ! phi = (1, x / ell), ell the power of 2 just above the region's largest |x|: g's
        ! entries are then pure numbers of at most the count of entries, so the LU's pivots
        ! (largest magnitude in a column, which would compare a count with a length) are
        ! the same in any units; a power of 2 changes no bit of E = phi . lambda
        ell = 1.0_dp
        if (any(region)) ell = maxval(abs(x), mask=spread(region, 1, dim))
        ell = merge(scale(1.0_dp, exponent(ell)), 1.0_dp, ell > 0.0_dp)
        do k = 1, dim
            g = 0.0_dp
            rhs = 0.0_dp
            ! two walks over the entries coupling component k with itself: the first takes
            ! the removed entries' mass and moments (rhs) and forms the receiving entries'
            ! system g; the second adds the solution's share to each receiving entry
            do pass = 1, 2
                do j = 1, mass%n
                    if (dof_comp(j) /= k) cycle
                    do p = mass%colptr(j) + 1, mass%colptr(j + 1)
                        i = mass%rowind(p) + 1
                        if (dof_comp(i) /= k) cycle
                        call classify(i, j, removed, receiving)
                        if (pass == 2) then
                            if (receiving) mass%val(p) = mass%val(p) + dot_product(phi, rhs)
                        else if (removed) then
                            rhs = rhs + mass%val(p) * phi
                            mass%val(p) = 0.0_dp
                        else if (receiving) then
                            g = g + spread(phi, 2, dim + 1) * spread(phi, 1, dim + 1)
                        end if
                    end do
                end do
                if (pass == 2) exit
                if (all(rhs == 0.0_dp)) exit
                info = 0
                if (moments_degenerate(dim + 1, g)) info = 1
                if (info == 0) call dense_lu_factor(dim + 1, g, piv, info)
                if (info /= 0) then
                    call raise(stat, errmsg, STAT_BAD_INPUT, 'mass redistribution: the nodes '// &
                               'next to the contact boundary cannot carry its mass and first moments')
                    return
                end if
                call dense_lu_solve(dim + 1, g, piv, rhs)
            end do
        end do

    contains

        !> Entry (ii, jj): removed (touches a contact node) or receiving (both in the
        !> region); phi = (1, (x_ii + x_jj)/(2 ell)).
        subroutine classify(ii, jj, rem, rec)
            integer, intent(in) :: ii, jj     !! row and column dof of the entry
            logical, intent(out) :: rem, rec  !! removed; receiving
            rem = contact_node(dof_node(ii)) .or. contact_node(dof_node(jj))
            rec = region(dof_node(ii)) .and. region(dof_node(jj))
            phi(1) = 1.0_dp
            phi(2:) = 0.5_dp * (x(:, dof_node(ii)) + x(:, dof_node(jj))) / ell
        end subroutine classify
    end subroutine mass_redistribute

    !> Whether the moment system g = sum phi phi^T (phi = (1, x), n = dim + 1) is singular
    !> in exact arithmetic: the receiving entries' midpoints lie on a point, a line or a
    !> plane, so that the first moments cannot all be matched (its LU meets a pivot of
    !> round-off size, not an exact zero, and the solve gives a round-off answer). Tested
    !> on the midpoints' covariance, centred and normalised, so that neither where the
    !> mesh lies nor its units matter: degenerate when a coordinate's variance is below
    !> VAR_RTOL of its mean square (constant up to round-off), or when a pivot of the
    !> correlation matrix (the share of a coordinate's variance the others leave
    !> unexplained) is below CORR_RTOL.
    pure logical function moments_degenerate(n, g) result(degenerate)
        integer, intent(in) :: n                     !! dim + 1
        real(dp), intent(in) :: g(n, n)              !! sum of phi phi^T over the entries
        !> Round-off of a variance formed as mean square - mean^2 is ~1e-16 of the mean
        !> square; a coordinate that varies is far above 1e-13 of it on any mesh whose
        !> extent is not below 1e-6 of its distance from the origin.
        real(dp), parameter :: VAR_RTOL = 1.0e-13_dp
        !> A flat set gives a pivot of round-off size; a mesh's receiving set, O(0.1-1).
        real(dp), parameter :: CORR_RTOL = 1.0e-8_dp
        real(dp) :: cov(n - 1, n - 1), c(n - 1), s(n - 1)
        integer :: piv(n - 1), info, i, j
        c = g(2:, 1) / g(1, 1)
        do j = 1, n - 1
            do i = 1, n - 1
                cov(i, j) = g(1 + i, 1 + j) / g(1, 1) - c(i) * c(j)
            end do
        end do
        degenerate = .true.
        do i = 1, n - 1
            if (.not. cov(i, i) > VAR_RTOL * g(1 + i, 1 + i) / g(1, 1)) return
            s(i) = 1.0_dp / sqrt(cov(i, i))
        end do
        do j = 1, n - 1
            do i = 1, n - 1
                cov(i, j) = cov(i, j) * s(i) * s(j)
            end do
        end do
        call dense_lu_factor(n - 1, cov, piv, info)
        if (info /= 0) return
        degenerate = any([(abs(cov(i, i)) < CORR_RTOL, i = 1, n - 1)])
    end function moments_degenerate
end module mass_redistribution
