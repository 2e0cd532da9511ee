!> The built-in bar meshes of the seed scene.
module bar_mesh
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_INTERNAL, raise
    use mesh, only: mesh_t
    implicit none
    private
    public :: bar_mesh_build

    !> Largest number of cells the built-in bar accepts.
    real(dp), parameter :: MAX_CELLS = 1.0e8_dp

contains

    !> Build the bar: dim = 1 segments on [0, length] (groups bottom = {x=0},
    !> top = {x=length}, body); dim = 2 the structured triangles of GetFEM's
    !> regular simplices mesh of [0, width] x [0, length] (same nodes and diagonals
    !> as shared/reference/meshes; groups bottom, top, left, right, body).
    !>
    !> 1D: n = max(1, nint(length/h)) segments, x_i = i*(length/n).
    !> 2D: nx = max(1, nint(width/h)), ny = max(1, nint(length/h)) squares of
    !> width/nx by length/ny, each cut into two triangles; the diagonal of square
    !> (i, j) (0-based) joins (i, j)-(i+1, j+1) when i+j is even and (i+1, j)-(i, j+1)
    !> when it is odd. Nodes, triangles (with their vertex order) and facets are
    !> numbered exactly as in GetFEM's export, so the reader gives the same arrays
    !> for the reference files. Groups: 1 bottom, 2 top, 3 left, 4 right, 5 body
    !> (1D: 1 bottom, 2 top, 3 body).
    !>
    !> 3D: the box [0, width] x [0, width] x [0, length] of nx = ny = max(1, nint(width/h))
    !> by nz = max(1, nint(length/h)) cuboids, each cut into the 6 tetrahedra around its
    !> diagonal from the lowest to the highest corner (GetFEM's regular simplices, same
    !> nodes and tetrahedra as shared/reference/meshes/bar3d_getfem_*.msh). Groups: 1 bottom
    !> (z = 0), 2 top (z = length), 3 left (x = 0), 4 right (x = width), 5 front (y = 0),
    !> 6 back (y = width), 7 sides (the four lateral faces), 8 body.
    subroutine bar_mesh_build(dim, length, width, h, msh, stat, errmsg)
        integer, intent(in) :: dim                          !! 1, 2 or 3
        real(dp), intent(in) :: length                      !! bar length (along x in 1D, y in 2D, z in 3D)
        real(dp), intent(in) :: width                       !! bar width (2D along x; 3D along x and y)
        real(dp), intent(in) :: h                           !! mesh size (square side)
        type(mesh_t), intent(out) :: msh                    !! the mesh
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=160) :: buf

        stat = STAT_OK
        if (dim < 1 .or. dim > 3) then
            write (buf, '(a, i0, a)') 'built-in bar: dim = ', dim, ' (must be 1, 2 or 3)'
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
            return
        end if
        if (.not. (ieee_is_finite(h) .and. h > 0)) then
            write (buf, '(a, g0, a)') 'built-in bar: h = ', h, ' (must be > 0)'
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
            return
        end if
        if (.not. (ieee_is_finite(length) .and. length > 0)) then
            write (buf, '(a, g0, a)') 'built-in bar: length = ', length, ' (must be > 0)'
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
            return
        end if
        if (dim >= 2 .and. .not. (ieee_is_finite(width) .and. width > 0)) then
            write (buf, '(a, g0, a)') 'built-in bar: width = ', width, ' (must be > 0)'
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
            return
        end if
        if (cell_count(dim, length, width, h) > MAX_CELLS) then
            write (buf, '(a, g0, a, es8.1, a)') 'built-in bar: h = ', h, &
                ' gives more than ', MAX_CELLS, ' cells'
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
            return
        end if
        if (dim == 1) then
            call build_1d(length, h, msh, stat, errmsg)
        else if (dim == 2) then
            call build_2d(length, width, h, msh, stat, errmsg)
        else
            call build_3d(length, width, h, msh, stat, errmsg)
        end if
    end subroutine bar_mesh_build

    !> Number of cells the bar would have (as a real, to avoid overflow).
    pure real(dp) function cell_count(dim, length, width, h)
        integer, intent(in) :: dim        !! 1, 2 or 3
        real(dp), intent(in) :: length    !! bar length
        real(dp), intent(in) :: width     !! bar width
        real(dp), intent(in) :: h         !! mesh size
        if (dim == 1) then
            cell_count = max(1.0_dp, length / h)
        else if (dim == 3) then
            cell_count = 6 * max(1.0_dp, length / h) * max(1.0_dp, width / h)**2
        else
            cell_count = 2 * max(1.0_dp, length / h) * max(1.0_dp, width / h)
        end if
    end function cell_count

    !> Allocate the arrays of `msh` for its counts.
    pure subroutine allocate_mesh(msh, stat, errmsg)
        type(mesh_t), intent(inout) :: msh                  !! mesh with counts set
        integer, intent(out) :: stat                        !! STAT_OK or STAT_INTERNAL
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: ist
        allocate (msh%x(msh%dim, msh%n_nodes), msh%cells(msh%dim + 1, msh%n_cells), &
                  msh%cell_group(msh%n_cells), msh%facets(msh%dim, msh%n_facets), &
                  msh%facet_group(msh%n_facets), msh%group_name(msh%n_groups), &
                  msh%group_dim(msh%n_groups), stat=ist)
        stat = STAT_OK
        if (ist /= 0) call raise(stat, errmsg, STAT_INTERNAL, 'built-in bar: out of memory')
    end subroutine allocate_mesh

    !> 1D bar: n segments on [0, length].
    pure subroutine build_1d(length, h, msh, stat, errmsg)
        real(dp), intent(in) :: length                      !! bar length
        real(dp), intent(in) :: h                           !! mesh size
        type(mesh_t), intent(inout) :: msh                  !! the mesh
        integer, intent(out) :: stat                        !! STAT_OK or STAT_INTERNAL
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: n, i
        real(dp) :: dx

        n = max(1, nint(length / h))
        dx = length / n
        msh%dim = 1
        msh%n_nodes = n + 1
        msh%n_cells = n
        msh%n_facets = 2
        msh%n_groups = 3
        call allocate_mesh(msh, stat, errmsg)
        if (stat /= STAT_OK) return
        do i = 0, n - 1
            msh%x(1, i + 1) = i * dx
            msh%cells(:, i + 1) = [i + 1, i + 2]
        end do
        msh%x(1, n + 1) = length
        msh%cell_group = 3
        msh%facets(1, :) = [1, n + 1]
        msh%facet_group = [1, 2]
        msh%group_name = [character(len=len(msh%group_name)) :: 'bottom', 'top', 'body']
        msh%group_dim = [0, 0, 1]
    end subroutine build_1d

    !> 2D bar: GetFEM's structured triangles of [0, width] x [0, length].
    subroutine build_2d(length, width, h, msh, stat, errmsg)
        real(dp), intent(in) :: length                      !! bar length (y)
        real(dp), intent(in) :: width                       !! bar width (x)
        real(dp), intent(in) :: h                           !! mesh size
        type(mesh_t), intent(inout) :: msh                  !! the mesh
        integer, intent(out) :: stat                        !! STAT_OK or STAT_INTERNAL
        character(len=*), intent(inout), optional :: errmsg !! message
        integer, allocatable :: num(:, :)
        integer :: nx, ny, i, j, k, c, f, p00, p10, p01, p11, ist
        real(dp) :: dx, dy

        nx = max(1, nint(width / h))
        ny = max(1, nint(length / h))
        dx = width / nx
        dy = length / ny
        msh%dim = 2
        msh%n_nodes = (nx + 1) * (ny + 1)
        msh%n_cells = 2 * nx * ny
        msh%n_facets = 2 * (nx + ny)
        msh%n_groups = 5
        call allocate_mesh(msh, stat, errmsg)
        if (stat /= STAT_OK) return
        allocate (num(0:nx, 0:ny), stat=ist)
        if (ist /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, 'built-in bar: out of memory')
            return
        end if

        ! GetFEM numbers the corners of the squares (i fastest) in the order
        ! (i,j), (i+1,j), (i,j+1), (i+1,j+1) as they first appear.
        num = 0
        k = 0
        c = 0
        do j = 0, ny - 1
            do i = 0, nx - 1
                call number_node(i, j)
                call number_node(i + 1, j)
                call number_node(i, j + 1)
                call number_node(i + 1, j + 1)
                p00 = num(i, j); p10 = num(i + 1, j)
                p01 = num(i, j + 1); p11 = num(i + 1, j + 1)
                if (modulo(i + j, 2) == 0) then
                    msh%cells(:, c + 1) = [p11, p00, p01]
                    msh%cells(:, c + 2) = [p11, p00, p10]
                else
                    msh%cells(:, c + 1) = [p10, p01, p00]
                    msh%cells(:, c + 2) = [p10, p01, p11]
                end if
                c = c + 2
            end do
        end do
        msh%cell_group = 5

        f = 0
        do i = 0, nx - 1
            f = f + 1
            msh%facets(:, f) = [num(i, 0), num(i + 1, 0)]
            msh%facet_group(f) = 1
        end do
        do i = 0, nx - 1
            f = f + 1
            msh%facets(:, f) = [num(i, ny), num(i + 1, ny)]
            msh%facet_group(f) = 2
        end do
        do j = 0, ny - 1
            f = f + 1
            msh%facets(:, f) = [num(0, j), num(0, j + 1)]
            msh%facet_group(f) = 3
        end do
        do j = 0, ny - 1
            f = f + 1
            msh%facets(:, f) = [num(nx, j), num(nx, j + 1)]
            msh%facet_group(f) = 4
        end do
        msh%group_name = [character(len=len(msh%group_name)) :: &
                          'bottom', 'top', 'left', 'right', 'body']
        msh%group_dim = [1, 1, 1, 1, 2]

    contains

        !> Give node (ii, jj) the next number if it has none yet.
        subroutine number_node(ii, jj)
            integer, intent(in) :: ii   !! column (0..nx)
            integer, intent(in) :: jj   !! row (0..ny)
            if (num(ii, jj) /= 0) return
            k = k + 1
            num(ii, jj) = k
            ! the last column/row lies exactly on x = width / y = length
            if (ii == nx) then
                msh%x(1, k) = width
            else
                msh%x(1, k) = ii * dx
            end if
            if (jj == ny) then
                msh%x(2, k) = length
            else
                msh%x(2, k) = jj * dy
            end if
        end subroutine number_node
    end subroutine build_2d

    !> 3D box: GetFEM's regular simplices of [0, width]^2 x [0, length]. The corners of
    !> each cuboid (i fastest, then j, then k) are numbered as they first appear, in the
    !> order of their offset bits (x, y, z) = 000, 100, 010, 110, 001, 101, 011, 111; its
    !> tetrahedra (in GetFEM's vertex order) share the edge 000-111.
    subroutine build_3d(length, width, h, msh, stat, errmsg)
        real(dp), intent(in) :: length                      !! box length (z)
        real(dp), intent(in) :: width                       !! box width (x and y)
        real(dp), intent(in) :: h                           !! mesh size
        type(mesh_t), intent(inout) :: msh                  !! the mesh
        integer, intent(out) :: stat                        !! STAT_OK or STAT_INTERNAL
        character(len=*), intent(inout), optional :: errmsg !! message
        ! the 6 tetrahedra of a cuboid as corner numbers 0..7 (bit 1 = x, 2 = y, 4 = z)
        integer, parameter :: TETS(4, 6) = reshape([3, 7, 0, 1, 7, 0, 5, 4, 7, 0, 1, 5, &
                                                    3, 7, 0, 2, 6, 7, 0, 4, 6, 7, 0, 2], [4, 6])
        integer, allocatable :: num(:, :, :)
        integer :: n(3), i, j, k, c, f, q, t, corner(0:7), ist
        real(dp) :: d(3), ext(3)

        n(1:2) = max(1, nint(width / h))
        n(3) = max(1, nint(length / h))
        ext = [width, width, length]
        d = ext / n
        msh%dim = 3
        msh%n_nodes = product(n + 1)
        msh%n_cells = 6 * product(n)
        ! bottom, top, left, right, front, back, then the four lateral faces again (sides)
        msh%n_facets = 2 * (2 * n(1) * n(2) + 2 * (2 * n(2) * n(3) + 2 * n(1) * n(3)))
        msh%n_groups = 8
        call allocate_mesh(msh, stat, errmsg)
        if (stat /= STAT_OK) return
        allocate (num(0:n(1), 0:n(2), 0:n(3)), stat=ist)
        if (ist /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, 'built-in bar: out of memory')
            return
        end if

        num = 0
        q = 0
        c = 0
        do k = 0, n(3) - 1
            do j = 0, n(2) - 1
                do i = 0, n(1) - 1
                    do t = 0, 7
                        corner(t) = number_node([i, j, k] + [iand(t, 1), iand(t, 2) / 2, iand(t, 4) / 4])
                    end do
                    do t = 1, 6
                        msh%cells(:, c + t) = corner(TETS(:, t))
                    end do
                    c = c + 6
                end do
            end do
        end do
        msh%cell_group = 8

        f = 0
        call face_group(3, 0, 1)        ! bottom: z = 0
        call face_group(3, n(3), 2)     ! top
        call face_group(1, 0, 3)        ! left: x = 0
        call face_group(1, n(1), 4)     ! right
        call face_group(2, 0, 5)        ! front: y = 0
        call face_group(2, n(2), 6)     ! back
        call face_group(1, 0, 7)        ! sides
        call face_group(1, n(1), 7)
        call face_group(2, 0, 7)
        call face_group(2, n(2), 7)
        msh%group_name = [character(len=len(msh%group_name)) :: &
                          'bottom', 'top', 'left', 'right', 'front', 'back', 'sides', 'body']
        msh%group_dim = [2, 2, 2, 2, 2, 2, 2, 3]

    contains

        !> The number of node ijk (0..n), given the next one if it has none yet.
        integer function number_node(ijk) result(id)
            integer, intent(in) :: ijk(3)   !! grid position
            integer :: a
            if (num(ijk(1), ijk(2), ijk(3)) == 0) then
                q = q + 1
                num(ijk(1), ijk(2), ijk(3)) = q
                do a = 1, 3   ! the last layer lies exactly on the box's face
                    if (ijk(a) == n(a)) then
                        msh%x(a, q) = ext(a)
                    else
                        msh%x(a, q) = ijk(a) * d(a)
                    end if
                end do
            end if
            id = num(ijk(1), ijk(2), ijk(3))
        end function number_node

        !> The triangles of the face {x_axis = layer}, 2 per square, cut along the
        !> diagonal from its lowest to its highest corner (the cuboids' cut), into group g.
        subroutine face_group(axis, layer, g)
            integer, intent(in) :: axis    !! 1, 2 or 3
            integer, intent(in) :: layer   !! grid index along axis
            integer, intent(in) :: g       !! group
            integer :: a, b, ia, ib, p(3), p00, p10, p01, p11
            a = merge(2, 1, axis == 1)        ! the face's axes a < b
            b = merge(2, 3, axis == 3)
            do ib = 0, n(b) - 1
                do ia = 0, n(a) - 1
                    p = 0
                    p(axis) = layer
                    p(a) = ia; p(b) = ib
                    p00 = num(p(1), p(2), p(3))
                    p(a) = ia + 1
                    p10 = num(p(1), p(2), p(3))
                    p(b) = ib + 1
                    p11 = num(p(1), p(2), p(3))
                    p(a) = ia
                    p01 = num(p(1), p(2), p(3))
                    msh%facets(:, f + 1) = [p00, p10, p11]
                    msh%facets(:, f + 2) = [p00, p01, p11]
                    msh%facet_group(f + 1:f + 2) = g
                    f = f + 2
                end do
            end do
        end subroutine face_group
    end subroutine build_3d
end module bar_mesh
