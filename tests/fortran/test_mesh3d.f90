!> Unit tests of the 3D mesh checks: the built-in box passes mesh_check, with triangle
!> facets owned by tetrahedra (the owner's opposite node off the facet); a tetrahedron of
!> zero volume, a triangle that is no face of any tetrahedron and a repeated facet node
!> are refused with messages naming them; a point group marks its nodes alone
!> (mesh_group_nodes), and its node or group numbers out of range are refused. Exit
!> status 1 (error stop) on any failure.
program test_mesh3d
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT
    use mesh, only: mesh_t, mesh_check, mesh_facet_owner, mesh_cell_size, mesh_group_nodes
    use bar_mesh, only: bar_mesh_build
    use unit_checks, only: checks_t
    implicit none
    type(checks_t) :: checks
    type(mesh_t) :: box, bad
    integer, allocatable :: owner(:), opposite(:)
    integer :: stat, f, c
    character(len=200) :: msg
    real(dp) :: meas, hmax, vol
    logical :: mask(4)

    call bar_mesh_build(3, 1.0_dp, 0.1_dp, 0.05_dp, box, stat, msg)
    call checks%check(stat == STAT_OK, 'box built')
    call mesh_check(box, stat, msg)
    call checks%check(stat == STAT_OK, 'box passes mesh_check')
    call mesh_facet_owner(box, owner, stat, msg, opposite)
    call checks%check(stat == STAT_OK .and. all(owner > 0), 'every box facet has an owner')
    do f = 1, box%n_facets
        call checks%check(.not. any(box%facets(:, f) == box%cells(opposite(f), owner(f))), &
                          'opposite node off the facet')
    end do
    vol = 0.0_dp
    do c = 1, box%n_cells
        call mesh_cell_size(box, c, meas, hmax)
        vol = vol + abs(meas)
        call checks%check(abs(hmax - sqrt(3.0_dp) * 0.05_dp) < 1.0e-15_dp, 'diameter = cube diagonal')
    end do
    call checks%check(abs(vol - 0.01_dp) < 1.0e-15_dp, 'volumes sum to the box')

    ! one tetrahedron, its four faces
    call one_tet(bad)
    call mesh_check(bad, stat, msg)
    call checks%check(stat == STAT_OK, 'a single tetrahedron passes')
    bad%x(:, 4) = [0.5_dp, 0.5_dp, 0.0_dp]     ! flat: in the plane of the others
    call check_refused('cell 1 is degenerate', 'zero-volume tetrahedron refused')
    call one_tet(bad)
    bad%facets(:, 2) = [1, 2, 2]
    call check_refused('facet 2 repeats a node', 'repeated facet node refused')
    call one_tet(bad)
    bad%n_nodes = 5
    bad%x = reshape([0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1], [3, 5]) * 1.0_dp
    bad%cells = reshape([1, 2, 3, 4, 2, 3, 4, 5], [4, 2])
    bad%n_cells = 2
    bad%cell_group = [1, 1]
    bad%facets(:, 1) = [1, 2, 5]
    call check_refused('facet 1 is not a face', 'a triangle that is no face refused')

    ! a point group 'tip' (the node opposite the face z = 0): its node alone is marked
    call one_tet(bad)
    call add_tip(bad)
    call mesh_check(bad, stat, msg)
    call checks%check(stat == STAT_OK, 'a tetrahedron with a point group passes')
    mask = .false.
    call mesh_group_nodes(bad, 'tip', mask, stat, msg)
    call checks%check(stat == STAT_OK .and. all(mask .eqv. [.false., .false., .false., .true.]), &
                      'the point group marks its node alone')
    mask = .false.
    call mesh_group_nodes(bad, 'tip,boundary', mask, stat, msg)
    call checks%check(stat == STAT_OK .and. all(mask), 'point and facet groups together')
    bad%lower_nodes = [5]
    call check_refused('group node 1 has a node number outside 1..4', &
                       'a point group node out of range refused')
    call add_tip(bad)
    bad%lower_group = [4]
    call check_refused('group node 1 has group index 4', 'a point group index out of range refused')
    ! (freed: a leak checker counts what the program still holds at its end as lost)
    deallocate (owner, opposite)
    call checks%finish('test_mesh3d')

contains

    !> mesh_check refuses `bad` (STAT_BAD_INPUT) with a message that holds `text`.
    subroutine check_refused(text, what)
        character(len=*), intent(in) :: text   !! what the message must say
        character(len=*), intent(in) :: what   !! the check's name
        msg = ''
        call mesh_check(bad, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT .and. index(msg, text) > 0, &
                          what//': '//trim(msg))
    end subroutine check_refused

    !> The unit tetrahedron with its four faces in one group.
    subroutine one_tet(m)
        type(mesh_t), intent(out) :: m
        m%dim = 3
        m%n_nodes = 4
        m%n_cells = 1
        m%n_facets = 4
        m%n_groups = 2
        m%x = reshape([0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1], [3, 4]) * 1.0_dp
        m%cells = reshape([1, 2, 3, 4], [4, 1])
        m%cell_group = [2]
        m%facets = reshape([1, 2, 3, 1, 2, 4, 1, 3, 4, 2, 3, 4], [3, 4])
        m%facet_group = [1, 1, 1, 1]
        m%group_name = [character(len=64) :: 'boundary', 'body']
        m%group_dim = [2, 3]
    end subroutine one_tet

    !> The point group 'tip' (group 3, dimension 0): node 4.
    subroutine add_tip(m)
        type(mesh_t), intent(inout) :: m
        m%n_groups = 3
        m%group_name = [character(len=64) :: 'boundary', 'body', 'tip']
        m%group_dim = [2, 3, 0]
        m%n_lower = 1
        m%lower_nodes = [4]
        m%lower_group = [3]
    end subroutine add_tip
end program test_mesh3d
