!> Geometry of one simplex (segment, triangle, tetrahedron) from its node coordinates,
!> pure: the signed measure and the diameter, and the 3D helpers they are built from.
!> The one place these formulas live: the mesh check (`mesh_cell_size`) and the P1
!> element kernels (`fe_p1`) and Nitsche's gamma = gamma0 / h both call them, so they
!> agree bit for bit.
module simplex_geometry
    use kinds, only: dp
    implicit none
    private

    public :: simplex_measure, simplex_diameter, simplex_edges, det3, cross, euclid_length

contains

    !> Signed measure of the cell: length in 1D, (signed) area in 2D, (signed) volume
    !> in 3D (positive when the edges from node 1 form a right-handed frame).
    pure function simplex_measure(dim, xe) result(m)
        integer, intent(in) :: dim          !! 1, 2 or 3
        real(dp), intent(in) :: xe(:, :)    !! (dim, dim+1) node coordinates
        real(dp) :: m
        if (dim == 1) then
            m = xe(1, 2) - xe(1, 1)
        else if (dim == 3) then
            m = det3(simplex_edges(xe)) / 6.0_dp
        else
            m = 0.5_dp * ((xe(1, 2) - xe(1, 1)) * (xe(2, 3) - xe(2, 1)) &
                          - (xe(1, 3) - xe(1, 1)) * (xe(2, 2) - xe(2, 1)))
        end if
    end function simplex_measure

    !> Diameter (longest edge) of the cell.
    pure function simplex_diameter(dim, xe) result(d)
        integer, intent(in) :: dim          !! 1, 2 or 3
        real(dp), intent(in) :: xe(:, :)    !! (dim, dim+1) node coordinates
        real(dp) :: d
        integer :: a, b
        if (dim == 1) then
            d = abs(xe(1, 2) - xe(1, 1))
        else if (dim == 3) then
            d = 0.0_dp
            do a = 1, 4
                do b = a + 1, 4
                    d = max(d, euclid_length(xe(:, b) - xe(:, a)))
                end do
            end do
        else
            d = max(euclid_length(xe(:, 2) - xe(:, 1)), &
                    euclid_length(xe(:, 3) - xe(:, 2)), euclid_length(xe(:, 1) - xe(:, 3)))
        end if
    end function simplex_diameter

    !> Euclidean length sqrt(sum(v**2)) of a vector of coordinates. Exactly homogeneous:
    !> v x 2^k gives the length x 2^k, so a mesh in other units gives the same numbers in
    !> those units (docs/numerics.md, "Units"). gfortran's norm2 is not: its scaled sum
    !> starts from the scale 1 and rounds otherwise once a component exceeds 1 in
    !> magnitude (the same bits as this below it). No guard against overflow: it is for
    !> coordinates (their squares overflow beyond 1e154).
    pure function euclid_length(v) result(d)
        real(dp), intent(in) :: v(:)        !! vector
        real(dp) :: d
        d = sqrt(sum(v**2))
    end function euclid_length

    !> Edges of a tetrahedron from node 1 as columns: [x2 - x1, x3 - x1, x4 - x1].
    pure function simplex_edges(xe) result(e)
        real(dp), intent(in) :: xe(:, :)     !! (3, 4) node coordinates
        real(dp) :: e(3, 3)
        e(:, 1) = xe(:, 2) - xe(:, 1)
        e(:, 2) = xe(:, 3) - xe(:, 1)
        e(:, 3) = xe(:, 4) - xe(:, 1)
    end function simplex_edges

    !> Determinant of a 3x3 matrix (triple product of its columns).
    pure function det3(e) result(d)
        real(dp), intent(in) :: e(3, 3)      !! matrix
        real(dp) :: d
        d = dot_product(e(:, 1), cross(e(:, 2), e(:, 3)))
    end function det3

    !> Cross product a x b.
    pure function cross(a, b) result(c)
        real(dp), intent(in) :: a(3)         !! first vector
        real(dp), intent(in) :: b(3)         !! second vector
        real(dp) :: c(3)
        c = [a(2) * b(3) - a(3) * b(2), a(3) * b(1) - a(1) * b(3), a(1) * b(2) - a(2) * b(1)]
    end function cross
end module simplex_geometry
