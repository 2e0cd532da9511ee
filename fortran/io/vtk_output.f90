!> Field snapshots for ParaView: ASCII VTK XML UnstructuredGrid (.vtu) files of a P1
!> mesh with displacement and velocity point data, and the .pvd collection index
!> that lists them with their times.
module vtk_output
    use kinds, only: dp, i8
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_INTERNAL, raise
    use os_files, only: write_text_atomic
    implicit none
    private

    integer, parameter, public :: VTK_LINE = 3       !! VTK cell type of a 2-node segment
    integer, parameter, public :: VTK_TRIANGLE = 5   !! VTK cell type of a 3-node triangle
    integer, parameter, public :: VTK_TETRA = 10     !! VTK cell type of a 4-node tetrahedron

    character(len=*), parameter :: REAL_FMT = '(3(1x,es24.16e3))'   ! round-trips doubles

    public :: vtk_write_vtu, vtk_write_pvd, vtk_vtu_bytes

contains

    !> Write an ASCII .vtu file of a P1 mesh: dim 1 segments (VTK_LINE), dim 2 triangles
    !> (VTK_TRIANGLE), dim 3 tetrahedra (VTK_TETRA). Points are padded to 3D with zeros;
    !> point data "displacement" and "velocity" have 3 components (padded with 0), plus
    !> an optional scalar point field. Connectivity is written 0-based. The file is
    !> replaced if it exists. STAT_BAD_INPUT on inconsistent shapes or cell indices
    !> out of 1..n, STAT_INTERNAL if the file cannot be written.
    subroutine vtk_write_vtu(path, dim, x, cells, u, v, stat, errmsg, scalar, scalar_name, time)
        character(len=*), intent(in) :: path                !! file to write (.vtu)
        integer, intent(in) :: dim                          !! space dimension 1, 2 or 3
        real(dp), intent(in) :: x(:, :)                     !! (dim, n) node coordinates
        integer, intent(in) :: cells(:, :)                  !! (dim+1, nc) 1-based node numbers
        real(dp), intent(in) :: u(:, :)                     !! (dim, n) displacement
        real(dp), intent(in) :: v(:, :)                     !! (dim, n) velocity
        integer, intent(out) :: stat                        !! STAT_OK, _BAD_INPUT, _INTERNAL
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: scalar(:)         !! (n) optional scalar point field
        character(len=*), intent(in), optional :: scalar_name !! its name (default 'scalar')
        real(dp), intent(in), optional :: time              !! optional TimeValue field data
        integer :: n, nc, unit, ios, k, ctype
        character(len=256) :: iomsg
        character(len=:), allocatable :: sname

        n = size(x, 2)
        nc = size(cells, 2)
        select case (dim)
        case (1); ctype = VTK_LINE
        case (2); ctype = VTK_TRIANGLE
        case (3); ctype = VTK_TETRA
        case default
            call raise(stat, errmsg, STAT_BAD_INPUT, 'vtk_write_vtu: dim must be 1, 2 or 3')
            return
        end select
        call check_arrays(dim, x, cells, u, v, stat, errmsg, scalar)
        if (stat /= STAT_OK) return
        sname = 'scalar'
        if (present(scalar_name)) sname = xml_escape(trim(scalar_name))

        call open_vtk(path, 'UnstructuredGrid', 'vtk_write_vtu', unit, ios, iomsg, stat, errmsg)
        if (stat /= STAT_OK) return
        if (ios == 0 .and. present(time)) then
            write (unit, '(a)', iostat=ios, iomsg=iomsg) '    <FieldData>'
            if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) &
                '      <DataArray type="Float64" Name="TimeValue" NumberOfTuples="1"' &
                //' format="ascii">'
            if (ios == 0) write (unit, '(es24.16e3)', iostat=ios, iomsg=iomsg) time
            if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '      </DataArray>'
            if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '    </FieldData>'
        end if
        if (ios == 0) write (unit, '(a,i0,a,i0,a)', iostat=ios, iomsg=iomsg) &
            '    <Piece NumberOfPoints="', n, '" NumberOfCells="', nc, '">'

        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) &
            '      <PointData Vectors="displacement">'
        if (ios == 0) call write_vectors(unit, 'displacement', dim, u, ios, iomsg)
        if (ios == 0) call write_vectors(unit, 'velocity', dim, v, ios, iomsg)
        if (ios == 0 .and. present(scalar)) then
            write (unit, '(a)', iostat=ios, iomsg=iomsg) &
                '        <DataArray type="Float64" Name="'//sname//'" format="ascii">'
            do k = 1, n
                if (ios /= 0) exit
                write (unit, '(es24.16e3)', iostat=ios, iomsg=iomsg) scalar(k)
            end do
            if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '        </DataArray>'
        end if
        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '      </PointData>'

        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '      <Points>'
        if (ios == 0) call write_vectors(unit, '', dim, x, ios, iomsg)
        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '      </Points>'

        if (ios == 0) call write_cells(unit, cells, ctype, ios, iomsg)
        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '    </Piece>'
        call close_vtk(unit, path, 'UnstructuredGrid', 'vtk_write_vtu', ios, iomsg, stat, errmsg)
    end subroutine vtk_write_vtu

    !> The shapes of vtk_write_vtu's arrays: x, u, v (dim, n), cells (dim+1, nc) with node
    !> numbers in 1..n, scalar (n).
    pure subroutine check_arrays(dim, x, cells, u, v, stat, errmsg, scalar)
        integer, intent(in) :: dim                          !! space dimension
        real(dp), intent(in) :: x(:, :)                     !! (dim, n) node coordinates
        integer, intent(in) :: cells(:, :)                  !! (dim+1, nc) node numbers
        real(dp), intent(in) :: u(:, :)                     !! (dim, n) displacement
        real(dp), intent(in) :: v(:, :)                     !! (dim, n) velocity
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: scalar(:)         !! (n) scalar point field
        integer :: n
        stat = STAT_OK
        n = size(x, 2)
        if (size(x, 1) /= dim .or. size(u, 1) /= dim .or. size(v, 1) /= dim &
            .or. size(u, 2) /= n .or. size(v, 2) /= n .or. size(cells, 1) /= dim + 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, &
                       'vtk_write_vtu: x, u, v must be (dim, n) and cells (dim+1, nc)')
            return
        end if
        if (present(scalar)) then
            if (size(scalar) /= n) then
                call raise(stat, errmsg, STAT_BAD_INPUT, &
                           'vtk_write_vtu: scalar must have n entries')
                return
            end if
        end if
        if (size(cells, 2) > 0) then
            if (minval(cells) < 1 .or. maxval(cells) > n) then
                call raise(stat, errmsg, STAT_BAD_INPUT, &
                           'vtk_write_vtu: cell node number out of range 1..n')
                return
            end if
        end if
    end subroutine check_arrays

    !> The <Cells> element: connectivity (0-based), offsets and the VTK cell type.
    subroutine write_cells(unit, cells, ctype, ios, iomsg)
        integer, intent(in) :: unit                         !! open formatted stream
        integer, intent(in) :: cells(:, :)                  !! (nv, nc) 1-based node numbers
        integer, intent(in) :: ctype                        !! VTK cell type
        integer, intent(out) :: ios                         !! iostat
        character(len=*), intent(inout) :: iomsg            !! iomsg
        integer :: k, nc
        nc = size(cells, 2)
        write (unit, '(a)', iostat=ios, iomsg=iomsg) '      <Cells>'
        if (ios == 0) call write_int_rows(unit, 'Int32', 'connectivity', cells - 1, ios, iomsg)
        if (ios == 0) call write_int_rows(unit, 'Int32', 'offsets', &
                                          reshape([(size(cells, 1) * k, k = 1, nc)], [1, nc]), &
                                          ios, iomsg)
        if (ios == 0) call write_int_rows(unit, 'UInt8', 'types', spread([ctype], 2, nc), &
                                          ios, iomsg)
        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '      </Cells>'
    end subroutine write_cells

    !> One integer DataArray of the given VTK type: a line per column of `rows` (at
    !> most 4 values a line).
    subroutine write_int_rows(unit, vtk_type, name, rows, ios, iomsg)
        integer, intent(in) :: unit                         !! open formatted stream
        character(len=*), intent(in) :: vtk_type            !! 'Int32', 'UInt8'
        character(len=*), intent(in) :: name                !! array name
        integer, intent(in) :: rows(:, :)                   !! (1..4, lines) values
        integer, intent(out) :: ios                         !! iostat
        character(len=*), intent(inout) :: iomsg            !! iomsg
        integer :: k
        write (unit, '(a)', iostat=ios, iomsg=iomsg) &
            '        <DataArray type="'//vtk_type//'" Name="'//name//'" format="ascii">'
        do k = 1, size(rows, 2)
            if (ios /= 0) exit
            write (unit, '(4(1x,i0))', iostat=ios, iomsg=iomsg) rows(:, k)
        end do
        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '        </DataArray>'
    end subroutine write_int_rows

    !> Write the ParaView collection index (.pvd) listing files(k) at times(k); file
    !> names are written as given (trimmed), so give them relative to the .pvd's folder.
    !> The index is replaced atomically (written as path.tmp and renamed over it), so that
    !> a reader, or a run killed while writing it, never leaves part of one.
    subroutine vtk_write_pvd(path, times, files, stat, errmsg)
        character(len=*), intent(in) :: path                !! file to write (.pvd)
        real(dp), intent(in) :: times(:)                    !! time of each snapshot
        character(len=*), intent(in) :: files(:)            !! snapshot file names (.vtu)
        integer, intent(out) :: stat                        !! STAT_OK, _BAD_INPUT, _INTERNAL
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=1), parameter :: nl = new_line('a')
        character(len=:), allocatable :: lines, line
        integer :: k, n, pos

        if (size(times) /= size(files)) then
            call raise(stat, errmsg, STAT_BAD_INPUT, &
                       'vtk_write_pvd: times and files differ in length')
            return
        end if
        ! the DataSet lines in one string: their length first (no copy a line)
        n = 0
        do k = 1, size(times)
            line = pvd_line(times(k), files(k))
            n = n + len(line)
        end do
        allocate (character(len=n) :: lines)
        pos = 0
        do k = 1, size(times)
            line = pvd_line(times(k), files(k))
            lines(pos + 1:pos + len(line)) = line
            pos = pos + len(line)
        end do
        call write_text_atomic(path, '<?xml version="1.0"?>'//nl// &
                               '<VTKFile type="Collection" version="0.1" '// &
                               'byte_order="LittleEndian">'//nl//'  <Collection>'//nl// &
                               lines//'  </Collection>'//nl//'</VTKFile>'//nl, stat, errmsg)
    end subroutine vtk_write_pvd

    !> The line (with its line feed) of a .pvd collection that lists `file` at `time`.
    pure function pvd_line(time, file) result(line)
        real(dp), intent(in) :: time            !! the snapshot's time
        character(len=*), intent(in) :: file    !! its file name, relative to the .pvd's folder
        character(len=:), allocatable :: line
        character(len=32) :: tbuf
        write (tbuf, '(es24.16e3)') time
        line = '    <DataSet timestep="'//trim(adjustl(tbuf))//'" group="" part="0" file="' &
               //xml_escape(trim(file))//'"/>'//new_line('a')
    end function pvd_line

    !> Open `path` (replaced) as a formatted stream and write the XML declaration and
    !> the opening tags <VTKFile type="kind" ...> and <kind>. A failed open is
    !> STAT_INTERNAL "<who>: cannot open <path>: <reason>"; a failed write is left in
    !> ios/iomsg for close_vtk to report.
    subroutine open_vtk(path, kind, who, unit, ios, iomsg, stat, errmsg)
        character(len=*), intent(in) :: path                !! file to write
        character(len=*), intent(in) :: kind                !! 'UnstructuredGrid' or 'Collection'
        character(len=*), intent(in) :: who                 !! procedure name (message)
        integer, intent(out) :: unit                        !! the open unit
        integer, intent(out) :: ios                         !! iostat of the writes
        character(len=*), intent(inout) :: iomsg            !! iomsg
        integer, intent(out) :: stat                        !! STAT_OK or STAT_INTERNAL
        character(len=*), intent(inout), optional :: errmsg !! message
        stat = STAT_OK
        open (newunit=unit, file=path, status='replace', action='write', form='formatted', &
              access='stream', iostat=ios, iomsg=iomsg)
        if (ios /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, who//': cannot open '//trim(path) &
                       //': '//trim(iomsg))
            return
        end if
        write (unit, '(a)', iostat=ios, iomsg=iomsg) '<?xml version="1.0"?>'
        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) &
            '<VTKFile type="'//kind//'" version="0.1" byte_order="LittleEndian">'
        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '  <'//kind//'>'
    end subroutine open_vtk

    !> Write the closing tags </kind> and </VTKFile> of a file of open_vtk and close it
    !> through close_checked (which reports a write that failed before).
    subroutine close_vtk(unit, path, kind, who, ios, iomsg, stat, errmsg)
        integer, intent(in) :: unit                         !! unit of open_vtk
        character(len=*), intent(in) :: path                !! its file
        character(len=*), intent(in) :: kind                !! as given to open_vtk
        character(len=*), intent(in) :: who                 !! procedure name (message)
        integer, intent(inout) :: ios                       !! status of the writes so far
        character(len=*), intent(inout) :: iomsg            !! message of the failed write
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '  </'//kind//'>'
        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '</VTKFile>'
        call close_checked(unit, path, ios, iomsg, who, stat, errmsg)
    end subroutine close_vtk

    !> Closes a file written through `unit` and reports any failure: a write error
    !> already met (ios /= 0), a failed close, or a closed file whose size differs from
    !> the bytes written. libgfortran does not report a failed write of its buffer (a full
    !> disk) at FLUSH or CLOSE, hence the size check.
    subroutine close_checked(unit, path, ios, iomsg, who, stat, errmsg)
        integer, intent(in) :: unit                         !! open unit
        character(len=*), intent(in) :: path                !! its file
        integer, intent(inout) :: ios                       !! status of the writes so far
        character(len=*), intent(inout) :: iomsg            !! message of the failed write
        character(len=*), intent(in) :: who                 !! procedure name (message)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(i8) :: expected
        integer :: k
        if (ios == 0) inquire (unit=unit, pos=expected)
        if (ios /= 0) then
            close (unit, iostat=k)
            call raise(stat, errmsg, STAT_INTERNAL, who//': cannot write '//trim(path) &
                       //': '//trim(iomsg))
            return
        end if
        close (unit, iostat=ios, iomsg=iomsg)
        if (ios /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, who//': cannot close '//trim(path) &
                       //': '//trim(iomsg))
            return
        end if
        call check_size(path, expected - 1, who, stat, errmsg)
    end subroutine close_checked

    !> STAT_INTERNAL unless the closed file holds `bytes` bytes (a write lost on a full
    !> disk shows up here).
    subroutine check_size(path, bytes, who, stat, errmsg)
        character(len=*), intent(in) :: path                !! file written
        integer(i8), intent(in) :: bytes                    !! bytes written to it
        character(len=*), intent(in) :: who                 !! procedure name (message)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(i8) :: size_now
        character(len=48) :: b1, b2
        stat = STAT_OK
        inquire (file=path, size=size_now)
        if (size_now == bytes) return
        write (b1, '(i0)') max(size_now, 0_i8)
        write (b2, '(i0)') bytes
        call raise(stat, errmsg, STAT_INTERNAL, who//': cannot write '//trim(path)//': '// &
                   trim(b1)//' of '//trim(b2)//' bytes written (disk full?)')
    end subroutine check_size

    !> One 3-component Float64 DataArray (rows of a (dim, n) array padded with zeros);
    !> name '' writes an unnamed array (the Points).
    subroutine write_vectors(unit, name, dim, a, ios, iomsg)
        integer, intent(in) :: unit                  !! open formatted unit
        character(len=*), intent(in) :: name         !! array name ('' for Points)
        integer, intent(in) :: dim                   !! rows of a used (1..3)
        real(dp), intent(in) :: a(:, :)              !! (dim, n) values
        integer, intent(out) :: ios                  !! iostat
        character(len=*), intent(inout) :: iomsg     !! iomsg
        real(dp) :: p(3)
        integer :: k
        if (len(name) > 0) then
            write (unit, '(a)', iostat=ios, iomsg=iomsg) &
                '        <DataArray type="Float64" Name="'//name &
                //'" NumberOfComponents="3" format="ascii">'
        else
            write (unit, '(a)', iostat=ios, iomsg=iomsg) &
                '        <DataArray type="Float64" NumberOfComponents="3" format="ascii">'
        end if
        p = 0.0_dp
        do k = 1, size(a, 2)
            if (ios /= 0) return
            p(1:dim) = a(1:dim, k)
            write (unit, REAL_FMT, iostat=ios, iomsg=iomsg) p
        end do
        if (ios == 0) write (unit, '(a)', iostat=ios, iomsg=iomsg) '        </DataArray>'
    end subroutine write_vectors

    !> Size in bytes of the file vtk_write_vtu writes for these cells on n nodes, without
    !> the optional scalar and time: the real lines exactly; the integers digit by digit.
    pure function vtk_vtu_bytes(dim, n, cells) result(bytes)
        integer, intent(in) :: dim                  !! space dimension 1, 2 or 3
        integer, intent(in) :: n                    !! number of nodes
        integer, intent(in) :: cells(:, :)          !! (dim+1, nc) 1-based node numbers
        integer(i8) :: bytes
        integer(i8), parameter :: REAL_LINE = 3 * 25 + 1   ! REAL_FMT and its newline
        integer(i8), parameter :: FIXED = 903               ! the tag lines and newlines
        integer :: k, nc
        nc = size(cells, 2)
        bytes = FIXED + digits10(int(n, i8)) + digits10(int(nc, i8)) + 3 * n * REAL_LINE
        do k = 1, nc
            bytes = bytes + sum(1 + digits10(int(cells(:, k) - 1, i8))) + 1 &  ! connectivity
                    + 1 + digits10(int(size(cells, 1), i8) * k) + 1 + 3        ! offsets, types
        end do
        if (dim < 1 .or. dim > 3) bytes = 0
    end function vtk_vtu_bytes

    !> Number of decimal digits of i >= 0.
    elemental integer(i8) function digits10(i)
        integer(i8), intent(in) :: i    !! a count
        integer(i8) :: j
        digits10 = 1
        j = i
        do while (j >= 10)
            j = j / 10
            digits10 = digits10 + 1
        end do
    end function digits10

    !> s with the XML special characters & < > " ' replaced by entities.
    pure function xml_escape(s) result(e)
        character(len=*), intent(in) :: s   !! raw text
        character(len=:), allocatable :: e
        integer :: k
        e = ''
        do k = 1, len(s)
            select case (s(k:k))
            case ('&'); e = e//'&amp;'
            case ('<'); e = e//'&lt;'
            case ('>'); e = e//'&gt;'
            case ('"'); e = e//'&quot;'
            case (''''); e = e//'&apos;'
            case default; e = e//s(k:k)
            end select
        end do
    end function xml_escape
end module vtk_output
