!> Simplicial meshes: nodes, cells (segments in 1D, triangles in 2D), tagged
!> boundary facets and named physical groups.
module mesh
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, raise
    implicit none
    private

    integer, parameter, public :: GROUP_NAME_LEN = 64   !! max length of a group name

    !> A mesh of dimension `dim` (spatial = cell dimension, 1 or 2).
    !> A facet that belongs to several groups is stored once per group.
    type, public :: mesh_t
        integer :: dim = 0                        !! 1 (segments) or 2 (triangles)
        integer :: n_nodes = 0                    !! number of nodes
        integer :: n_cells = 0                    !! number of cells
        integer :: n_facets = 0                   !! number of tagged boundary facets
        integer :: n_groups = 0                   !! number of physical groups
        real(dp), allocatable :: x(:, :)          !! (dim, n_nodes) coordinates
        integer, allocatable :: cells(:, :)       !! (dim+1, n_cells) 1-based node numbers, any orientation
        integer, allocatable :: cell_group(:)     !! (n_cells) group index of each cell, 0 = none
        integer, allocatable :: facets(:, :)      !! (dim, n_facets) facet nodes (a point in 1D, a segment in 2D)
        integer, allocatable :: facet_group(:)    !! (n_facets) group index of each facet
        character(len=GROUP_NAME_LEN), allocatable :: group_name(:)  !! (n_groups)
        integer, allocatable :: group_dim(:)      !! (n_groups) dimension of the group's entities
    end type mesh_t

    public :: mesh_free, mesh_check, mesh_find_group, mesh_group_nodes, mesh_group_facets

contains

    !> Release all arrays and reset the sizes.
    subroutine mesh_free(this)
        type(mesh_t), intent(inout) :: this   !! mesh to reset
        this = mesh_t()
    end subroutine mesh_free

    !> Check consistency: sizes, node numbers in range, no degenerate cell
    !> (|measure| <= 1e-12 * h^dim with h the cell's longest edge), facet nodes in range.
    subroutine mesh_check(this, stat, errmsg)
        type(mesh_t), intent(in) :: this                  !! mesh to check
        integer, intent(out) :: stat                      !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! what is wrong (cell number, ...)
        stat = STAT_OK
        if (this%dim < 1) call raise(stat, errmsg, STAT_BAD_INPUT, 'mesh_check: not implemented')
    end subroutine mesh_check

    !> Index of the group called `name` (case-sensitive, blanks trimmed), 0 if absent.
    pure function mesh_find_group(this, name) result(idx)
        type(mesh_t), intent(in) :: this      !! mesh
        character(len=*), intent(in) :: name  !! group name
        integer :: idx
        idx = 0
    end function mesh_find_group

    !> Mark the nodes of every facet or cell in the comma-separated list of groups
    !> `names` (blank entries ignored; '' marks nothing). An unknown name gives
    !> STAT_BAD_INPUT with errmsg = "group 'NAME' not in mesh".
    subroutine mesh_group_nodes(this, names, mask, stat, errmsg)
        type(mesh_t), intent(in) :: this                  !! mesh
        character(len=*), intent(in) :: names             !! e.g. 'left,right'
        logical, intent(inout) :: mask(:)                 !! (n_nodes) set .true. on the groups' nodes
        integer, intent(out) :: stat                      !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message naming the missing group
        stat = STAT_OK
        mask = mask
        if (len_trim(names) > 0) call raise(stat, errmsg, STAT_BAD_INPUT, 'not implemented')
    end subroutine mesh_group_nodes

    !> Indices (into facets(:, :)) of the facets of the comma-separated groups `names`,
    !> each facet once. Errors as mesh_group_nodes.
    subroutine mesh_group_facets(this, names, list, stat, errmsg)
        type(mesh_t), intent(in) :: this                  !! mesh
        character(len=*), intent(in) :: names             !! e.g. 'bottom'
        integer, allocatable, intent(out) :: list(:)      !! facet indices (size 0 if names = '')
        integer, intent(out) :: stat                      !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message naming the missing group
        stat = STAT_OK
        allocate (list(0))
        if (len_trim(names) > 0) call raise(stat, errmsg, STAT_BAD_INPUT, 'not implemented')
    end subroutine mesh_group_facets
end module mesh
