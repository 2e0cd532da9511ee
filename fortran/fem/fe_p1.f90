!> P1 Lagrange elements: segments (1D bar), triangles (plane strain) and tetrahedra
!> (3D isotropic elasticity), pure kernels. Dofs of a cell are ordered node by node:
!> (u1x, u1y, u2x, u2y, ...) in 2D, (u1x, u1y, u1z, u2x, ...) in 3D.
module fe_p1
    use kinds, only: dp
    use simplex_geometry, only: simplex_measure, simplex_edges, det3, cross
    implicit none
    private

    public :: p1_gradients, p1_stiffness, p1_mass, p1_lame

contains

    !> Lame parameters (lambda, mu) from Young's modulus and Poisson's ratio.
    pure subroutine p1_lame(young, poisson, lambda, mu)
        real(dp), intent(in) :: young     !! E > 0
        real(dp), intent(in) :: poisson   !! nu in (-1, 1/2)
        real(dp), intent(out) :: lambda   !! E nu / ((1 + nu)(1 - 2 nu))
        real(dp), intent(out) :: mu       !! E / (2 (1 + nu))
        lambda = young * poisson / ((1.0_dp + poisson) * (1.0_dp - 2.0_dp * poisson))
        mu = young / (2.0_dp * (1.0_dp + poisson))
    end subroutine p1_lame

    !> Gradients of the dim+1 shape functions (constant on the cell); either
    !> orientation. grad(:, a) = grad phi_a.
    pure subroutine p1_gradients(dim, xe, grad)
        integer, intent(in) :: dim            !! 1, 2 or 3
        real(dp), intent(in) :: xe(:, :)      !! (dim, dim+1) node coordinates
        real(dp), intent(out) :: grad(:, :)   !! (dim, dim+1)
        real(dp) :: det, e(3, 3)
        if (dim == 1) then
            det = xe(1, 2) - xe(1, 1)
            grad(1, 1) = -1.0_dp / det
            grad(1, 2) = 1.0_dp / det
        else if (dim == 3) then
            ! grad phi_{a+1} = row a of J^-1, J = [x2 - x1, x3 - x1, x4 - x1] (columns):
            ! J^-1 = cofactor^T / det J; the rows are cross products of J's columns
            e = simplex_edges(xe)
            det = det3(e)
            grad(:, 2) = cross(e(:, 2), e(:, 3)) / det
            grad(:, 3) = cross(e(:, 3), e(:, 1)) / det
            grad(:, 4) = cross(e(:, 1), e(:, 2)) / det
            grad(:, 1) = -(grad(:, 2) + grad(:, 3) + grad(:, 4))
        else
            det = 2.0_dp * simplex_measure(2, xe)
            grad(:, 1) = [xe(2, 2) - xe(2, 3), xe(1, 3) - xe(1, 2)] / det
            grad(:, 2) = [xe(2, 3) - xe(2, 1), xe(1, 1) - xe(1, 3)] / det
            grad(:, 3) = [xe(2, 1) - xe(2, 2), xe(1, 2) - xe(1, 1)] / det
        end if
    end subroutine p1_gradients

    !> Element stiffness: 1D E u' v' (per unit cross-section); 2D plane strain
    !> and 3D isotropic elasticity. ke is (n, n) with n = dim (dim+1).
    pure subroutine p1_stiffness(dim, xe, lambda, mu, young, ke)
        integer, intent(in) :: dim           !! 1, 2 or 3
        real(dp), intent(in) :: xe(:, :)     !! (dim, dim+1) node coordinates
        real(dp), intent(in) :: lambda       !! Lame lambda (2D, 3D)
        real(dp), intent(in) :: mu           !! Lame mu (2D, 3D)
        real(dp), intent(in) :: young        !! E (1D)
        real(dp), intent(out) :: ke(:, :)    !! (dim (dim+1), dim (dim+1))
        real(dp) :: grad(dim, dim + 1), area, bmat(3, 6), dmat(3, 3)
        integer :: a
        call p1_gradients(dim, xe, grad)
        area = abs(simplex_measure(dim, xe))
        if (dim == 1) then
            ke(:, 1) = young * area * grad(1, 1) * grad(1, :)
            ke(:, 2) = young * area * grad(1, 2) * grad(1, :)
            return
        end if
        if (dim == 3) then
            call tet_stiffness(grad, area, lambda, mu, ke)
            return
        end if
        bmat = 0.0_dp
        do a = 1, 3
            bmat(1, 2 * a - 1) = grad(1, a)
            bmat(2, 2 * a) = grad(2, a)
            bmat(3, 2 * a - 1) = grad(2, a)
            bmat(3, 2 * a) = grad(1, a)
        end do
        dmat = reshape([lambda + 2 * mu, lambda, 0.0_dp, &
                        lambda, lambda + 2 * mu, 0.0_dp, &
                        0.0_dp, 0.0_dp, mu], [3, 3])
        ke = area * matmul(transpose(bmat), matmul(dmat, bmat))
    end subroutine p1_stiffness

    !> Element mass, consistent (exact for P1) or row-sum lumped.
    pure subroutine p1_mass(dim, xe, density, lumped, me)
        integer, intent(in) :: dim           !! 1, 2 or 3
        real(dp), intent(in) :: xe(:, :)     !! (dim, dim+1) node coordinates
        real(dp), intent(in) :: density      !! rho
        logical, intent(in) :: lumped        !! .true.: diagonal (row sums)
        real(dp), intent(out) :: me(:, :)    !! (dim (dim+1), dim (dim+1))
        real(dp) :: m, scalar(dim + 1, dim + 1)
        integer :: a, b, k, nn
        nn = dim + 1
        m = density * abs(simplex_measure(dim, xe))
        if (lumped) then
            scalar = 0.0_dp
            do a = 1, nn
                scalar(a, a) = m / nn
            end do
        else
            ! int phi_a phi_b = |T| (1 + delta_ab) / ((n+1)(n+2)) on a simplex of dim n
            scalar = m / real(nn * (nn + 1), dp)
            do a = 1, nn
                scalar(a, a) = 2.0_dp * m / real(nn * (nn + 1), dp)
            end do
        end if
        me = 0.0_dp
        do b = 1, nn
            do a = 1, nn
                do k = 1, dim
                    me(dim * (a - 1) + k, dim * (b - 1) + k) = scalar(a, b)
                end do
            end do
        end do
    end subroutine p1_mass

    !> Tetrahedron stiffness vol B^T D B, Voigt order (xx, yy, zz, yz, xz, xy) with
    !> engineering shear strains.
    pure subroutine tet_stiffness(grad, vol, lambda, mu, ke)
        real(dp), intent(in) :: grad(3, 4)   !! shape-function gradients
        real(dp), intent(in) :: vol          !! |T|
        real(dp), intent(in) :: lambda       !! Lame lambda
        real(dp), intent(in) :: mu           !! Lame mu
        real(dp), intent(out) :: ke(:, :)    !! (12, 12)
        real(dp) :: bmat(6, 12), dmat(6, 6)
        integer :: a, k
        bmat = 0.0_dp
        do a = 1, 4
            k = 3 * (a - 1)
            bmat(1, k + 1) = grad(1, a)
            bmat(2, k + 2) = grad(2, a)
            bmat(3, k + 3) = grad(3, a)
            bmat(4, k + 2) = grad(3, a)
            bmat(4, k + 3) = grad(2, a)
            bmat(5, k + 1) = grad(3, a)
            bmat(5, k + 3) = grad(1, a)
            bmat(6, k + 1) = grad(2, a)
            bmat(6, k + 2) = grad(1, a)
        end do
        dmat = 0.0_dp
        dmat(1:3, 1:3) = lambda
        do a = 1, 3
            dmat(a, a) = lambda + 2.0_dp * mu
            dmat(a + 3, a + 3) = mu
        end do
        ke = vol * matmul(transpose(bmat), matmul(dmat, bmat))
    end subroutine tet_stiffness
end module fe_p1
