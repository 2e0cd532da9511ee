!> Simplicial meshes: nodes, cells (segments in 1D, triangles in 2D, tetrahedra in
!> 3D), tagged boundary facets, the nodes of the groups of a lower dimension (points;
!> curves in 3D) and named physical groups.
module mesh
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use kinds, only: dp
    use simplex_geometry, only: simplex_measure, simplex_diameter
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_INTERNAL, raise
    use text, only: real_text
    implicit none
    private

    integer, parameter, public :: GROUP_NAME_LEN = 64   !! max length of a group name

    !> Relative size below which a cell counts as degenerate (see mesh_check).
    real(dp), parameter :: DEGENERATE_TOL = 1.0e-12_dp

    !> A mesh of dimension `dim` (spatial = cell dimension, 1, 2 or 3).
    !> A facet that belongs to several groups is stored once per group.
    type, public :: mesh_t
        integer :: dim = 0                        !! 1 (segments), 2 (triangles) or 3 (tetrahedra)
        integer :: n_nodes = 0                    !! number of nodes
        integer :: n_cells = 0                    !! number of cells
        integer :: n_facets = 0                   !! number of tagged boundary facets
        integer :: n_groups = 0                   !! number of physical groups
        real(dp), allocatable :: x(:, :)          !! (dim, n_nodes) coordinates
        integer, allocatable :: cells(:, :)       !! (dim+1, n_cells) 1-based node numbers, any orientation
        integer, allocatable :: cell_group(:)     !! (n_cells) group index of each cell, 0 = none
        integer, allocatable :: facets(:, :)      !! (dim, n_facets) facet nodes (a point in 1D, a segment in 2D, a triangle in 3D)
        integer, allocatable :: facet_group(:)    !! (n_facets) group index of each facet
        character(len=GROUP_NAME_LEN), allocatable :: group_name(:)  !! (n_groups)
        integer, allocatable :: group_dim(:)      !! (n_groups) dimension of the group's entities
        integer :: n_lower = 0                    !! (group, node) pairs of the groups below dim-1
        integer, allocatable :: lower_nodes(:)    !! (n_lower) nodes of the groups of dimension
                                                  !! < dim-1 (Physical Points; Curves in 3D),
                                                  !! once per group, sorted by group then node;
                                                  !! unallocated = none
        integer, allocatable :: lower_group(:)    !! (n_lower) group index of each such node
    end type mesh_t

    public :: mesh_free, mesh_check, mesh_find_group, mesh_group_nodes, mesh_group_facets
    public :: mesh_facet_owner, mesh_cell_size, mesh_parts

contains

    !> Release all arrays and reset the sizes.
    pure subroutine mesh_free(this)
        type(mesh_t), intent(inout) :: this   !! mesh to reset
        this = mesh_t()
    end subroutine mesh_free

    !> Check consistency: sizes, node numbers in range, no degenerate cell
    !> (|measure| <= 1e-12 * h^dim with h the cell's longest edge), facet nodes in range.
    !> Also: finite coordinates, group indices in range, distinct facet nodes,
    !> every facet a face of some cell (see mesh_facet_owner), every node in a cell.
    pure subroutine mesh_check(this, stat, errmsg)
        type(mesh_t), intent(in) :: this                  !! mesh to check
        integer, intent(out) :: stat                      !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! what is wrong (cell number, ...)
        integer, allocatable :: owner(:)
        character(len=320) :: buf
        integer :: c, f, k, nv
        real(dp) :: meas, hmax

        call check_sizes(this, stat, errmsg)
        if (stat /= STAT_OK) return
        nv = this%dim + 1

        if (.not. all(ieee_is_finite(this%x))) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'mesh check: non-finite node coordinates')
            return
        end if
        do c = 1, this%n_cells
            if (any(this%cells(:, c) < 1 .or. this%cells(:, c) > this%n_nodes)) then
                call refuse_item(stat, errmsg, 'cell', c, ' has a node number outside 1..', &
                                 this%n_nodes)
                return
            end if
            if (this%cell_group(c) < 0 .or. this%cell_group(c) > this%n_groups) then
                call refuse_item(stat, errmsg, 'cell', c, ' has group index ', this%cell_group(c))
                return
            end if
            call mesh_cell_size(this, c, meas, hmax)
            if (abs(meas) <= DEGENERATE_TOL * hmax**this%dim) then
                write (buf, '(a, i0, a)') 'mesh check: cell ', c, ' is degenerate ('
                call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf)// &
                           trim(merge('volume ', 'measure', this%dim == 3))//' '// &
                           real_text(abs(meas), 4)//', longest edge '//real_text(hmax, 4)//')')
                return
            end if
        end do
        do f = 1, this%n_facets
            if (any(this%facets(:, f) < 1 .or. this%facets(:, f) > this%n_nodes)) then
                call refuse_item(stat, errmsg, 'facet', f, ' has a node number outside 1..', &
                                 this%n_nodes)
                return
            end if
            do k = 2, this%dim
                if (any(this%facets(1:k - 1, f) == this%facets(k, f))) then
                    write (buf, '(a, i0, a)') 'mesh check: facet ', f, ' repeats a node'
                    call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
                    return
                end if
            end do
            if (this%facet_group(f) < 1 .or. this%facet_group(f) > this%n_groups) then
                call refuse_item(stat, errmsg, 'facet', f, ' has group index ', this%facet_group(f))
                return
            end if
        end do
        do k = 1, this%n_lower
            if (this%lower_nodes(k) < 1 .or. this%lower_nodes(k) > this%n_nodes) then
                call refuse_item(stat, errmsg, 'group node', k, ' has a node number outside 1..', &
                                 this%n_nodes)
                return
            end if
            if (this%lower_group(k) < 1 .or. this%lower_group(k) > this%n_groups) then
                call refuse_item(stat, errmsg, 'group node', k, ' has group index ', &
                                 this%lower_group(k))
                return
            end if
        end do
        call mesh_facet_owner(this, owner, stat, errmsg)
        if (stat /= STAT_OK) return
        call check_nodes_used(this, stat, errmsg)
    end subroutine mesh_check

    !> The number of parts of the mesh that share no node (connected components of the
    !> cells through their nodes; nodes in no cell do not count): 1 for one body. Two
    !> parts that touch through coincident but distinct nodes (a mesh whose duplicate
    !> nodes were not merged) count as two.
    integer function mesh_parts(msh) result(parts)
        type(mesh_t), intent(in) :: msh          !! mesh
        integer, allocatable :: parent(:)        ! (heap: a large mesh's would not fit the stack)
        logical, allocatable :: used(:)
        integer :: c, k, a, b
        allocate (parent(msh%n_nodes), used(msh%n_nodes))
        parent = [(k, k = 1, msh%n_nodes)]
        used = .false.
        do c = 1, msh%n_cells
            used(msh%cells(:, c)) = .true.
            a = root(msh%cells(1, c))
            do k = 2, size(msh%cells, 1)
                b = root(msh%cells(k, c))
                if (a /= b) parent(b) = a
            end do
        end do
        parts = 0
        do k = 1, msh%n_nodes
            if (used(k) .and. root(k) == k) parts = parts + 1
        end do
    contains
        !> The representative of node n's part (path halving on the way up).
        integer function root(n) result(r)
            integer, intent(in) :: n   !! node
            r = n
            do while (parent(r) /= r)
                parent(r) = parent(parent(r))
                r = parent(r)
            end do
        end function root
    end function mesh_parts

    !> Refuse item i of a mesh_check (`what` = 'cell' or 'facet') with the message
    !> 'mesh check: <what> <i><problem><value>', e.g. 'mesh check: cell 7 has group index -1'.
    pure subroutine refuse_item(stat, errmsg, what, i, problem, value)
        integer, intent(out) :: stat                        !! STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! the message
        character(len=*), intent(in) :: what                !! 'cell' or 'facet'
        integer, intent(in) :: i                            !! its index
        character(len=*), intent(in) :: problem             !! what is wrong, up to the value
        integer, intent(in) :: value                        !! the number the message ends with
        character(len=320) :: buf
        write (buf, '(a, i0, a, i0)') 'mesh check: '//what//' ', i, problem, value
        call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
    end subroutine refuse_item

    !> Every node belongs to a cell (a free node would make the stiffness singular).
    pure subroutine check_nodes_used(this, stat, errmsg)
        type(mesh_t), intent(in) :: this                  !! mesh (node numbers in range)
        integer, intent(out) :: stat                      !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message naming the node
        logical, allocatable :: used(:)
        character(len=320) :: buf
        integer :: c, i
        stat = STAT_OK
        allocate (used(this%n_nodes))
        used = .false.
        do c = 1, this%n_cells
            used(this%cells(:, c)) = .true.
        end do
        if (all(used)) return
        i = findloc(used, .false., dim=1)
        write (buf, '(a, i0, a, i0, a)') 'mesh check: node ', i, ' (and ', count(.not. used) - 1, &
            ' more) belongs to no cell (the cells are the '//element_kind(this%dim)// &
            '; elements of a lower dimension outside a physical group are dropped)'
        call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
    end subroutine check_nodes_used

    !> Shapes and sizes of the arrays of `this` agree with its counters.
    pure subroutine check_sizes(this, stat, errmsg)
        type(mesh_t), intent(in) :: this                  !! mesh to check
        integer, intent(out) :: stat                      !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! what is wrong
        character(len=320) :: buf
        logical :: ok
        integer :: d

        stat = STAT_OK
        d = this%dim
        if (d < 1 .or. d > 3) then
            write (buf, '(a, i0, a)') 'mesh check: dimension ', d, ' is not 1, 2 or 3'
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
            return
        end if
        if (this%n_nodes < d + 1 .or. this%n_cells < 1) then
            write (buf, '(a, i0, a, i0, a)') 'mesh check: too small (', this%n_nodes, &
                ' nodes, ', this%n_cells, ' cells)'
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
            return
        end if
        if (this%n_facets < 0 .or. this%n_groups < 0 .or. this%n_lower < 0) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'mesh check: negative facet or group count')
            return
        end if
        if (this%n_lower > 0) then
            ok = allocated(this%lower_nodes) .and. allocated(this%lower_group)
            if (ok) ok = size(this%lower_nodes) == this%n_lower &
                         .and. size(this%lower_group) == this%n_lower
            if (.not. ok) then
                call raise(stat, errmsg, STAT_BAD_INPUT, &
                           'mesh check: lower_nodes or lower_group differ from n_lower')
                return
            end if
        end if
        ok = allocated(this%x) .and. allocated(this%cells) .and. allocated(this%cell_group) &
             .and. allocated(this%facets) .and. allocated(this%facet_group) &
             .and. allocated(this%group_name) .and. allocated(this%group_dim)
        if (.not. ok) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'mesh check: arrays not allocated')
            return
        end if
        ok = size(this%x, 1) == d .and. size(this%x, 2) == this%n_nodes &
             .and. size(this%cells, 1) == d + 1 .and. size(this%cells, 2) == this%n_cells &
             .and. size(this%cell_group) == this%n_cells &
             .and. size(this%facets, 1) == d .and. size(this%facets, 2) == this%n_facets &
             .and. size(this%facet_group) == this%n_facets &
             .and. size(this%group_name) == this%n_groups &
             .and. size(this%group_dim) == this%n_groups
        if (.not. ok) then
            call raise(stat, errmsg, STAT_BAD_INPUT, &
                       'mesh check: array shapes differ from the counts')
        end if
    end subroutine check_sizes

    !> Signed measure (length in 1D, area in 2D, volume in 3D) and longest edge of cell `c`,
    !> the same numbers as the element kernels' (simplex_geometry).
    pure subroutine mesh_cell_size(this, c, meas, hmax)
        type(mesh_t), intent(in) :: this   !! mesh (nodes of cell c must be in range)
        integer, intent(in) :: c           !! cell index
        real(dp), intent(out) :: meas      !! signed length (1D), area (2D, > 0 counter-clockwise), volume (3D)
        real(dp), intent(out) :: hmax      !! longest edge (diameter) of the cell
        real(dp) :: xe(this%dim, this%dim + 1)
        xe = this%x(:, this%cells(:, c))
        meas = simplex_measure(this%dim, xe)
        hmax = simplex_diameter(this%dim, xe)
    end subroutine mesh_cell_size

    !> For every facet, a cell that has it as a face and the local number
    !> (1..dim+1) of the cell's node opposite to it. A facet that is no face of any
    !> cell gives STAT_BAD_INPUT.
    pure subroutine mesh_facet_owner(this, owner, stat, errmsg, opposite)
        type(mesh_t), intent(in) :: this                  !! mesh (node numbers in range)
        integer, allocatable, intent(out) :: owner(:)     !! (n_facets) owning cell of each facet
        integer, intent(out) :: stat                      !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message naming the facet
        integer, allocatable, intent(out), optional :: opposite(:) !! (n_facets) opposite local node
        integer, allocatable :: first(:), list(:)
        character(len=320) :: buf
        integer :: c, f, k, j, nv, loc

        stat = STAT_OK
        nv = this%dim + 1
        allocate (owner(this%n_facets))
        owner = 0
        if (present(opposite)) then
            allocate (opposite(this%n_facets))
            opposite = 0
        end if
        call node_cells(this, first, list)
        do f = 1, this%n_facets
            do k = first(this%facets(1, f)), first(this%facets(1, f) + 1) - 1
                c = list(k)
                loc = 0
                do j = 1, nv
                    if (.not. any(this%facets(:, f) == this%cells(j, c))) then
                        if (loc /= 0) then   ! two cell nodes outside the facet
                            loc = -1
                            exit
                        end if
                        loc = j
                    end if
                end do
                if (loc > 0) then
                    owner(f) = c
                    if (present(opposite)) opposite(f) = loc
                    exit
                end if
            end do
            if (owner(f) == 0) then
                write (buf, '(a, i0, a)') 'mesh check: facet ', f, ' is not a face of any cell'
                if (this%facet_group(f) >= 1 .and. this%facet_group(f) <= this%n_groups) then
                    buf = trim(buf)//" (group '"//trim(this%group_name(this%facet_group(f)))//"')"
                end if
                ! the cells are the elements of the highest dimension, the others facets
                buf = trim(buf)//': the cells are the '//element_kind(this%dim)// &
                      '; a mesh mixing cells of two dimensions is not supported'
                call raise(stat, errmsg, STAT_BAD_INPUT, trim(buf))
                return
            end if
        end do
    end subroutine mesh_facet_owner

    !> Node-to-cell incidence in compressed form: the cells of node i are
    !> list(first(i) : first(i+1)-1).
    pure subroutine node_cells(this, first, list)
        type(mesh_t), intent(in) :: this            !! mesh (node numbers in range)
        integer, allocatable, intent(out) :: first(:) !! (n_nodes+1) offsets
        integer, allocatable, intent(out) :: list(:)  !! (nv*n_cells) cell numbers
        allocate (first(this%n_nodes + 1), list(size(this%cells)))
        ! the entries of cells(:, :) in storage order, bucketed by node: entry e is in cell
        ! (e - 1) / nv + 1, in increasing order within each node's range
        call buckets(reshape(this%cells, [size(this%cells)]), first, list)
        list = (list - 1) / size(this%cells, 1) + 1
    end subroutine node_cells

    !> Counting sort of entries by bucket: the entries e with key(e) = i are
    !> list(first(i) : first(i+1)-1), in increasing order of e; entries with key 0 are
    !> left out (list's tail past first(size(first)) - 1 is then not set).
    pure subroutine buckets(key, first, list)
        integer, intent(in) :: key(:)       !! bucket of each entry, 0..size(first)-1 (0: none)
        integer, intent(out) :: first(:)    !! (buckets + 1) offsets into list
        integer, intent(inout) :: list(:)   !! (>= entries with a bucket) entry numbers
        integer :: fill(size(first) - 1)
        integer :: e, i
        fill = 0
        do e = 1, size(key)
            if (key(e) > 0) fill(key(e)) = fill(key(e)) + 1
        end do
        first(1) = 1
        do i = 1, size(fill)
            first(i + 1) = first(i) + fill(i)
        end do
        fill = 0
        do e = 1, size(key)
            i = key(e)
            if (i == 0) cycle
            list(first(i) + fill(i)) = e
            fill(i) = fill(i) + 1
        end do
    end subroutine buckets

    !> Index of the group called `name` (case-sensitive, blanks trimmed), 0 if absent.
    pure function mesh_find_group(this, name) result(idx)
        type(mesh_t), intent(in) :: this      !! mesh
        character(len=*), intent(in) :: name  !! group name
        integer :: idx
        integer :: g
        idx = 0
        if (.not. allocated(this%group_name)) return
        do g = 1, min(this%n_groups, size(this%group_name))
            if (trim(this%group_name(g)) == trim(adjustl(name))) then
                idx = g
                return
            end if
        end do
    end function mesh_find_group

    !> Group indices of the comma-separated list `names` (blank entries ignored).
    !> An unknown name gives STAT_BAD_INPUT "group 'NAME' not in mesh, whose groups are ...".
    pure subroutine parse_group_list(this, names, groups, stat, errmsg)
        type(mesh_t), intent(in) :: this                  !! mesh
        character(len=*), intent(in) :: names             !! e.g. 'left,right'
        integer, allocatable, intent(out) :: groups(:)    !! group indices, in list order
        integer, intent(out) :: stat                      !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message naming the missing group
        integer :: start, comma, g, n
        character(len=len(names)) :: item

        stat = STAT_OK
        allocate (groups(count([(names(g:g) == ',', g = 1, len(names))]) + 1))
        n = 0
        start = 1
        do while (start <= len(names))
            comma = index(names(start:), ',')
            if (comma == 0) then
                item = names(start:)
                start = len(names) + 1
            else
                item = names(start:start + comma - 2)
                start = start + comma
            end if
            if (len_trim(item) == 0) cycle
            g = mesh_find_group(this, item)
            if (g == 0) then
                call raise(stat, errmsg, STAT_BAD_INPUT, &
                           "group '"//trim(adjustl(item))//"' not in mesh"// &
                           group_names_text(this))
                return
            end if
            n = n + 1
            groups(n) = g
        end do
        groups = groups(1:n)
    end subroutine parse_group_list

    !> ", whose groups are 'a', 'b', ..." (the mesh's physical group names, in mesh order,
    !> cut after about 300 characters with ", ..."), or ", which has no groups": what a
    !> message about a missing group adds, so that it says which names to use instead.
    pure function group_names_text(this) result(text)
        type(mesh_t), intent(in) :: this   !! mesh
        character(len=:), allocatable :: text
        integer, parameter :: MAX_LEN = 300
        integer :: g, n
        n = 0
        if (allocated(this%group_name)) n = min(this%n_groups, size(this%group_name))
        if (n == 0) then
            text = ', which has no groups'
            return
        end if
        text = ', whose groups are '
        do g = 1, n
            if (g > 1) text = text//', '
            if (len(text) > MAX_LEN) then
                text = text//'...'
                return
            end if
            text = text//"'"//trim(this%group_name(g))//"'"
        end do
    end function group_names_text

    !> Mark the nodes of the groups in the comma-separated list `names` (blank entries
    !> ignored; '' marks nothing): the nodes of their facets or cells, and for a group of
    !> a lower dimension (a Physical Point; a Physical Curve of a 3D mesh) its nodes.
    !> An unknown name gives STAT_BAD_INPUT with errmsg = "group 'NAME' not in mesh"; a
    !> group with no element in the mesh gives STAT_BAD_INPUT too, saying what its
    !> elements are.
    pure subroutine mesh_group_nodes(this, names, mask, stat, errmsg)
        type(mesh_t), intent(in) :: this                  !! mesh
        character(len=*), intent(in) :: names             !! e.g. 'left,right'
        logical, intent(inout) :: mask(:)                 !! (n_nodes) set .true. on group nodes
        integer, intent(out) :: stat                      !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message naming the missing group
        integer, allocatable :: groups(:)
        integer :: k, g
        logical :: found

        call parse_group_list(this, names, groups, stat, errmsg)
        if (stat /= STAT_OK) return
        if (size(groups) > 0 .and. size(mask) /= this%n_nodes) then
            call raise(stat, errmsg, STAT_INTERNAL, &
                       'mesh_group_nodes: mask size differs from n_nodes')
            return
        end if
        do k = 1, size(groups)
            g = groups(k)
            found = .false.
            call mark_group_nodes(this%facets, this%facet_group, g, mask, found)
            call mark_group_nodes(this%cells, this%cell_group, g, mask, found)
            if (this%n_lower > 0) then
                call mark_group_nodes(reshape(this%lower_nodes, [1, this%n_lower]), &
                                      this%lower_group, g, mask, found)
            end if
            if (.not. found) then
                call raise(stat, errmsg, STAT_BAD_INPUT, &
                           "group '"//trim(this%group_name(g))// &
                           "' has no facets or cells in the mesh (its elements are "// &
                           element_kind(this%group_dim(g))//'; the facets and cells of a '// &
                           achar(iachar('0') + this%dim)//'D mesh are '// &
                           element_kind(this%dim - 1)//' and '//element_kind(this%dim)//')')
                return
            end if
        end do
    end subroutine mesh_group_nodes

    !> mask = .true. on the nodes of the elements (facets or cells) of group g; found
    !> becomes .true. if there is one.
    pure subroutine mark_group_nodes(elements, element_group, g, mask, found)
        integer, intent(in) :: elements(:, :)       !! (nodes per element, elements) node numbers
        integer, intent(in) :: element_group(:)     !! (elements) group of each
        integer, intent(in) :: g                    !! the group
        logical, intent(inout) :: mask(:)           !! (n_nodes) marked nodes
        logical, intent(inout) :: found             !! set when group g has an element here
        integer :: e
        do e = 1, size(elements, 2)
            if (element_group(e) == g) then
                mask(elements(:, e)) = .true.
                found = .true.
            end if
        end do
    end subroutine mark_group_nodes

    !> Indices (into facets(:, :)) of the facets of the comma-separated groups `names`,
    !> each facet once. Errors as mesh_group_nodes. A facet stored for several of
    !> the groups (same nodes) is listed once, by its first index; the list is sorted.
    !> A group without facets (e.g. the cell group 'body') gives STAT_BAD_INPUT.
    pure subroutine mesh_group_facets(this, names, list, stat, errmsg)
        type(mesh_t), intent(in) :: this                  !! mesh
        character(len=*), intent(in) :: names             !! e.g. 'bottom'
        integer, allocatable, intent(out) :: list(:)      !! facet indices (size 0 if names = '')
        integer, intent(out) :: stat                      !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message naming the missing group
        integer, allocatable :: groups(:)
        logical, allocatable :: take(:)
        integer :: k, g

        allocate (list(0))
        call parse_group_list(this, names, groups, stat, errmsg)
        if (stat /= STAT_OK .or. size(groups) == 0) return
        allocate (take(this%n_facets))
        take = .false.
        do k = 1, size(groups)
            g = groups(k)
            if (.not. any(this%facet_group == g)) then
                call raise(stat, errmsg, STAT_BAD_INPUT, "group '"//trim(this%group_name(g))// &
                           "' has no facets in the mesh (its elements are "// &
                           element_kind(this%group_dim(g))//'; the facets of a '// &
                           achar(iachar('0') + this%dim)//'D mesh are '// &
                           element_kind(this%dim - 1)//')')
                return
            end if
            where (this%facet_group == g) take = .true.
        end do
        call drop_duplicate_facets(this, take)
        list = pack([(k, k = 1, this%n_facets)], take)
    end subroutine mesh_group_facets

    !> The elements of dimension d, as messages name them: 'points', 'segments',
    !> 'triangles', 'tetrahedra'.
    pure function element_kind(d) result(s)
        integer, intent(in) :: d   !! element dimension
        character(len=:), allocatable :: s
        select case (d)
        case (0)
            s = 'points'
        case (1)
            s = 'segments'
        case (2)
            s = 'triangles'
        case (3)
            s = 'tetrahedra'
        case default
            s = 'of an unknown kind'
        end select
    end function element_kind

    !> Among the facets with take = .true., keep only the first of those with
    !> the same node set. Facets are bucketed by their smallest node.
    pure subroutine drop_duplicate_facets(this, take)
        type(mesh_t), intent(in) :: this        !! mesh
        logical, intent(inout) :: take(:)       !! (n_facets) selection to thin out
        integer, allocatable :: first(:), key(:), list(:)
        integer :: f, i, a, b, k
        allocate (first(this%n_nodes + 1), key(this%n_facets), list(this%n_facets))
        do f = 1, this%n_facets
            key(f) = 0
            if (take(f)) key(f) = minval(this%facets(:, f))
        end do
        call buckets(key, first, list)   ! increasing f: the first index comes first in each bucket
        do i = 1, this%n_nodes
            do a = first(i), first(i + 1) - 1
                f = list(a)
                if (.not. take(f)) cycle
                do b = a + 1, first(i + 1) - 1
                    k = list(b)
                    if (take(k) .and. same_nodes(this%facets(:, f), this%facets(:, k))) &
                        take(k) = .false.
                end do
            end do
        end do
    end subroutine drop_duplicate_facets

    !> Whether two node lists hold the same nodes (any order, no repeats).
    pure logical function same_nodes(a, b)
        integer, intent(in) :: a(:)   !! first list
        integer, intent(in) :: b(:)   !! second list, same size
        integer :: i
        same_nodes = .true.
        do i = 1, size(a)
            if (.not. any(b == a(i))) then
                same_nodes = .false.
                return
            end if
        end do
    end function same_nodes
end module mesh
