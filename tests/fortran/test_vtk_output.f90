!> Unit tests of module vtk_output: writes small 1D/2D .vtu files and a .pvd index
!> (into the folder given as first argument, default '.'), re-reads them as text and
!> checks the counts, types and 0-based connectivity; bad shapes are rejected.
!> Exit status 1 (error stop) on any failure.
program test_vtk_output
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_INTERNAL, MSG_LEN
    use kinds, only: i8
    use vtk_output, only: vtk_write_vtu, vtk_write_pvd, vtk_vtu_bytes
    use unit_checks, only: checks_t
    implicit none

    type(checks_t) :: checks
    character(len=512) :: dir

    dir = '.'
    if (command_argument_count() >= 1) call get_command_argument(1, dir)

    call test_triangles()
    call test_segments()
    call test_pvd()
    call test_size()
    call test_bad_input()

    call checks%finish('test_vtk_output')

contains


    !> Unit square split into two triangles.
    subroutine test_triangles()
        real(dp) :: x(2, 4), u(2, 4), v(2, 4), s(4)
        integer :: cells(3, 2), stat, k
        character(len=MSG_LEN) :: msg
        character(len=:), allocatable :: text, path
        x = reshape([0, 0, 1, 0, 1, 1, 0, 1], [2, 4]) * 1.0_dp
        cells = reshape([1, 2, 3, 1, 3, 4], [3, 2])
        u = reshape([(0.1_dp * k, k = 1, 8)], [2, 4])
        v = -u
        s = [1.0_dp, 2.0_dp, 3.0_dp, 4.0_dp]
        path = trim(dir)//'/test_vtk_tri.vtu'
        msg = ''
        call vtk_write_vtu(path, 2, x, cells, u, v, stat, msg, scalar=s, &
                           scalar_name='p_n', time=0.5_dp)
        call checks%check(stat == STAT_OK, 'tri: stat '//trim(msg))
        text = read_text(path)
        call checks%check(index(text, 'NumberOfPoints="4" NumberOfCells="2"') > 0, 'tri: counts')
        call checks%check(index(text, 'Name="displacement" NumberOfComponents="3"') > 0, 'tri: u')
        call checks%check(index(text, 'Name="velocity" NumberOfComponents="3"') > 0, 'tri: v')
        call checks%check(index(text, 'Name="p_n"') > 0, 'tri: scalar')
        call checks%check(index(text, 'Name="TimeValue"') > 0, 'tri: time')
        call checks%check(index(text, ' 0 1 2'//new_line('a')//' 0 2 3') > 0, 'tri: 0-based cells')
        call checks%check(index(text, ' 3'//new_line('a')//' 6') > 0, 'tri: offsets')
        call checks%check(index(text, '</VTKFile>') > 0, 'tri: closed')
    end subroutine test_triangles

    !> Three segments on [0, 1].
    subroutine test_segments()
        real(dp) :: x(1, 4), u(1, 4), v(1, 4)
        integer :: cells(2, 3), stat
        character(len=:), allocatable :: text, path
        x(1, :) = [0.0_dp, 1.0_dp / 3, 2.0_dp / 3, 1.0_dp]
        cells = reshape([1, 2, 2, 3, 3, 4], [2, 3])
        u(1, :) = 0.5_dp - x(1, :) / 2
        v = 0.0_dp
        path = trim(dir)//'/test_vtk_line.vtu'
        call vtk_write_vtu(path, 1, x, cells, u, v, stat)
        call checks%check(stat == STAT_OK, 'line: stat')
        text = read_text(path)
        call checks%check(index(text, 'NumberOfPoints="4" NumberOfCells="3"') > 0, 'line: counts')
        call checks%check(index(text, ' 2 3'//new_line('a')//'        </DataArray>') > 0, 'line: cells')
        call checks%check(index(text, ' 3'//new_line('a')//' 3'//new_line('a')//' 3') > 0, &
                   'line: VTK_LINE types')
    end subroutine test_segments

    !> vtk_vtu_bytes (the run's estimate of its field output) equals the size of the file
    !> written, for segments and for a grid of triangles with node numbers of 1 to 4
    !> digits (0-based numbers 0..1088) and cells from 1 to 4 digits.
    subroutine test_size()
        real(dp), allocatable :: x(:, :), u(:, :), v(:, :)
        integer, allocatable :: cells(:, :)
        integer :: stat, i, j, m, n, c, unit
        integer(i8) :: size_on_disk
        character(len=:), allocatable :: path
        path = trim(dir)//'/test_vtk_size.vtu'
        do m = 1, 32, 31                       ! (m+1)^2 nodes, 2 m^2 triangles
            n = (m + 1)**2
            allocate (x(2, n), u(2, n), v(2, n), cells(3, 2 * m * m))
            do j = 0, m
                do i = 0, m
                    x(:, 1 + i + j * (m + 1)) = [real(i, dp), -real(j, dp) / 3]
                end do
            end do
            u = -x / 7; v = x * 1.0e-300_dp
            c = 0
            do j = 0, m - 1
                do i = 1, m
                    cells(:, c + 1) = [i + j * (m + 1), i + 1 + j * (m + 1), i + (j + 1) * (m + 1)]
                    cells(:, c + 2) = [i + 1 + j * (m + 1), i + 1 + (j + 1) * (m + 1), &
                                       i + (j + 1) * (m + 1)]
                    c = c + 2
                end do
            end do
            call vtk_write_vtu(path, 2, x, cells, u, v, stat)
            open (newunit=unit, file=path, access='stream')
            inquire (unit=unit, size=size_on_disk)
            close (unit)
            call checks%check(stat == STAT_OK .and. size_on_disk == vtk_vtu_bytes(2, n, cells), &
                              'size: triangles')
            call vtk_write_vtu(path, 1, x(1:1, :), cells(1:2, :), u(1:1, :), v(1:1, :), stat)
            open (newunit=unit, file=path, access='stream')
            inquire (unit=unit, size=size_on_disk)
            close (unit, status='delete')
            call checks%check(stat == STAT_OK .and. &
                              size_on_disk == vtk_vtu_bytes(1, n, cells(1:2, :)), 'size: segments')
            deallocate (x, u, v, cells)
        end do
    end subroutine test_size

    subroutine test_pvd()
        character(len=20) :: files(2)
        integer :: stat
        character(len=:), allocatable :: text, path
        files = [character(len=20) :: 'test_vtk_tri.vtu', 'a&b.vtu']
        path = trim(dir)//'/test_vtk.pvd'
        call vtk_write_pvd(path, [0.0_dp, 0.25_dp], files, stat)
        call checks%check(stat == STAT_OK, 'pvd: stat')
        text = read_text(path)
        call checks%check(index(text, 'type="Collection"') > 0, 'pvd: collection')
        call checks%check(index(text, 'file="test_vtk_tri.vtu"/>') > 0, 'pvd: first file')
        call checks%check(index(text, 'timestep="2.5') > 0, 'pvd: second time')
        call checks%check(index(text, 'file="a&amp;b.vtu"') > 0, 'pvd: escaped name')
    end subroutine test_pvd

    subroutine test_bad_input()
        real(dp) :: x(2, 3), u(2, 3)
        integer :: stat
        character(len=MSG_LEN) :: msg
        character(len=4) :: files(1)
        x = 0.0_dp
        u = 0.0_dp
        msg = ''
        call vtk_write_vtu(trim(dir)//'/bad.vtu', 2, x, reshape([1, 2, 4], [3, 1]), u, u, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: node 4 of 3')
        call vtk_write_vtu(trim(dir)//'/bad.vtu', 2, x, reshape([1, 2], [2, 1]), u, u, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: cells (2, nc) in 2D')
        call vtk_write_vtu(trim(dir)//'/bad.vtu', 4, x, reshape([1, 2], [2, 1]), u, u, stat, msg)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: dim 4')
        call vtk_write_vtu(trim(dir)//'/no/such/dir/x.vtu', 2, x, reshape([1, 2, 3], [3, 1]), &
                           u, u, stat, msg)
        call checks%check(stat == STAT_INTERNAL, 'bad: unwritable path')
        call checks%check(index(msg, 'no/such/dir') > 0, 'bad: message names the path')
        files = 'a'
        call vtk_write_pvd(trim(dir)//'/bad.pvd', [0.0_dp, 1.0_dp], files, stat)
        call checks%check(stat == STAT_BAD_INPUT, 'bad: pvd lengths')
    end subroutine test_bad_input

    !> Whole file as one string, lines joined by new_line('a').
    function read_text(path) result(text)
        character(len=*), intent(in) :: path   !! file
        character(len=:), allocatable :: text
        character(len=1024) :: line
        integer :: unit, ios
        text = ''
        open (newunit=unit, file=path, status='old', action='read', iostat=ios)
        if (ios /= 0) return
        do
            read (unit, '(a)', iostat=ios) line
            if (ios /= 0) exit
            text = text//trim(line)//new_line('a')
        end do
        close (unit)
    end function read_text
end program test_vtk_output
