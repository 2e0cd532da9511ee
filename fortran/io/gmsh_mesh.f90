!> Mesh files read through gmsh's own API (fortran/io/gmsh_shim.c, which loads libgmsh at
!> run time): msh 2.2 and 4.x, ASCII or binary, and .geo geometries meshed in-process.
!>
!> Conventions (shared with python/dyncontact/mesh_io.py, applied by the shim):
!> - nodes are numbered 1..n in increasing order of their gmsh tags;
!> - groups are the named physical groups by (dimension, tag), which is the order of
!>   $PhysicalNames in every file gmsh writes, then the unnamed ones (named by their tag,
!>   e.g. '7') in order of first use by an entity;
!> - the mesh dimension is the highest element dimension (1 segments, 2 triangles,
!>   3 tetrahedra); cells are its elements, entity by entity, each with the first physical
!>   group of its entity (0 if none);
!> - facets (elements of dimension dim-1) are stored once per physical group of their
!>   entity; facets of entities without a physical group are dropped;
!> - the physical groups of a lower dimension (points; curves in 3D) keep their nodes
!>   (lower_nodes, lower_group: once per group and node, sorted by group then node);
!> - x holds the first dim coordinates; the others must be constant.
module gmsh_mesh
    use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_ptr, c_long_long, &
        c_null_char, c_null_ptr
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_INTERNAL, raise, MSG_LEN
    use mesh, only: mesh_t, mesh_check, GROUP_NAME_LEN
    use text, only: lower, real_text, int_text
    use msh_sections, only: msh_check_counts
    use os_files, only: read_whole_file, real_path
    implicit none
    private
    public :: read_mesh_file, gmsh_available, file_extension, estimate_geo_cells, too_large_text, &
              unmeshed_text, geo_given, geo_check_commands
    public :: GEO_GIVEN_H, GEO_GIVEN_LENGTH, GEO_GIVEN_WIDTH, GEO_GIVEN_ALL

    !> The bits of `given`, the .geo parameters the scene gives (geo_given): each is set
    !> as the file's parameter of that name; one not given is set only where the file
    !> uses it without defining it (a file's DefineConstant keeps its own value), and h
    !> not given leaves a file that uses no h its own sizes (gmsh_shim.c, geo_parse).
    integer, parameter :: GEO_GIVEN_H = 1, GEO_GIVEN_LENGTH = 2, GEO_GIVEN_WIDTH = 4
    !> Every parameter given (the readers' default, as gmsh -setnumber of all three).
    integer, parameter :: GEO_GIVEN_ALL = 7

    !> How scan_geo reaches a file: the .geo read (merged by gmsh), a file it includes
    !> (parsed as .geo), a file it merges (parsed as .geo unless gmsh reads it otherwise).
    integer, parameter :: GEO_TOP = 0, GEO_INCLUDED = 1, GEO_MERGED = 2
    !> Files nested deeper than this under the .geo read are refused (scan_geo).
    integer, parameter :: GEO_MAX_DEPTH = 20

    !> Relative tolerance of the test that dropped coordinates are constant.
    real(dp), parameter :: PLANE_TOL = 1.0e-10_dp

    interface
        !> 1 if libgmsh can be loaded; otherwise 0 and why in msg (gmsh_shim.c).
        function c_gmsh_available(msg, msglen) result(ok) bind(C, name='dc_gmsh_available')
            import :: c_int, c_char
            character(kind=c_char), intent(out) :: msg(*)  !! why not (when 0)
            integer(c_int), value :: msglen                !! length of msg
            integer(c_int) :: ok
        end function c_gmsh_available
        !> Read path into out with gmsh: 0, else 2 for bad input (another value: internal), and
        !> msg; 5: a .geo estimated above 2 x max_elements, not meshed (est, no msg).
        function c_gmsh_read(path, params, is_geo, out, est, msg, msglen) result(st) &
            bind(C, name='dc_gmsh_read')
            import :: c_int, c_char, c_double, c_ptr
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated mesh or .geo file
            real(c_double), intent(in) :: params(5)        !! h, length, width (a .geo's variables),
                                                           !! given (GEO_GIVEN_* bits),
                                                           !! max_elements (0: no estimate)
            integer(c_int), value :: is_geo                !! 1: mesh a .geo in-process
            type(c_ptr), intent(out) :: out                !! the mesh read (free with c_gmsh_free)
            real(c_double), intent(out) :: est(4)          !! estimate (-1: none), measure, size,
                                                           !! margin of the refusal
            character(kind=c_char), intent(out) :: msg(*)  !! why it failed
            integer(c_int), value :: msglen                !! length of msg
            integer(c_int) :: st
        end function c_gmsh_read
        !> A .geo's element count estimated before meshing (no mesh is made): 0, else 2.
        function c_gmsh_estimate(path, params, est, msg, msglen) result(st) &
            bind(C, name='dc_gmsh_estimate')
            import :: c_int, c_char, c_double
            character(kind=c_char), intent(in) :: path(*)  !! NUL-terminated .geo file
            real(c_double), intent(in) :: params(4)        !! h, length, width, given (bits)
            real(c_double), intent(out) :: est(4)          !! estimate (-1: none), measure, size,
                                                           !! margin of the refusal
            character(kind=c_char), intent(out) :: msg(*)  !! why it failed
            integer(c_int), value :: msglen                !! length of msg
            integer(c_int) :: st
        end function c_gmsh_estimate
        !> Sizes of a mesh read by c_gmsh_read.
        subroutine c_gmsh_sizes(p, dim, n_nodes, n_cells, n_facets, n_groups, names_len) &
            bind(C, name='dc_gmsh_sizes')
            import :: c_int, c_ptr, c_long_long
            type(c_ptr), value :: p  !! mesh from c_gmsh_read
            integer(c_int), intent(out) :: dim, n_groups, names_len
                !! dimension, groups, length of the names
            integer(c_long_long), intent(out) :: n_nodes, n_cells, n_facets  !! nodes, cells, facets
        end subroutine c_gmsh_sizes
        !> Copy the arrays of a mesh read by c_gmsh_read (sizes from c_gmsh_sizes).
        subroutine c_gmsh_arrays(p, xyz, cells, cell_group, facets, facet_group, group_dim, &
                                 names) bind(C, name='dc_gmsh_arrays')
            import :: c_int, c_ptr, c_double, c_char
            type(c_ptr), value :: p                          !! mesh from c_gmsh_read
            real(c_double), intent(out) :: xyz(*)            !! (3, n_nodes) coordinates
            integer(c_int), intent(out) :: cells(*), cell_group(*), facets(*), facet_group(*)
                !! 1-based connectivity and groups
            integer(c_int), intent(out) :: group_dim(*)      !! (n_groups) each group's dimension
            character(kind=c_char), intent(out) :: names(*)  !! (names_len) the groups' names
        end subroutine c_gmsh_arrays
        !> Number of (group, node) pairs of the groups of a lower dimension of a mesh read
        !> by c_gmsh_read.
        subroutine c_gmsh_lower_size(p, n_lower) bind(C, name='dc_gmsh_lower_size')
            import :: c_ptr, c_long_long
            type(c_ptr), value :: p                      !! mesh from c_gmsh_read
            integer(c_long_long), intent(out) :: n_lower !! pairs
        end subroutine c_gmsh_lower_size
        !> Copy those pairs (sizes from c_gmsh_lower_size).
        subroutine c_gmsh_lower_arrays(p, nodes, group) bind(C, name='dc_gmsh_lower_arrays')
            import :: c_ptr, c_int
            type(c_ptr), value :: p                      !! mesh from c_gmsh_read
            integer(c_int), intent(out) :: nodes(*)      !! 1-based node numbers
            integer(c_int), intent(out) :: group(*)      !! 1-based group indices
        end subroutine c_gmsh_lower_arrays
        !> The refusal of an entity of a physical group that has no elements (gmsh_shim.c).
        subroutine c_unmeshed_text(d, tag, group, cells_dim, from_file, out, len) &
            bind(C, name='dc_unmeshed_text')
            import :: c_int, c_char
            integer(c_int), value :: d, tag                  !! the entity's dimension and tag
            character(kind=c_char), intent(in) :: group(*)   !! NUL-terminated group name
            integer(c_int), value :: cells_dim               !! the cells' dimension
            integer(c_int), value :: from_file               !! 1: a mesh file; 0: a .geo meshed
            character(kind=c_char), intent(out) :: out(*)    !! the text, NUL-terminated
            integer(c_int), value :: len                     !! length of out
        end subroutine c_unmeshed_text
        !> Free a mesh read by c_gmsh_read.
        subroutine c_gmsh_free(p) bind(C, name='dc_gmsh_free')
            import :: c_ptr
            type(c_ptr), value :: p  !! mesh from c_gmsh_read
        end subroutine c_gmsh_free
    end interface

contains

    !> The `given` bits (GEO_GIVEN_*) of a scene that gives &mesh h, length, width or not.
    pure integer function geo_given(h, length, width)
        logical, intent(in) :: h                 !! &mesh h given
        logical, intent(in) :: length            !! &mesh length given
        logical, intent(in) :: width             !! &mesh width given
        geo_given = merge(GEO_GIVEN_H, 0, h) + merge(GEO_GIVEN_LENGTH, 0, length) + &
                    merge(GEO_GIVEN_WIDTH, 0, width)
    end function geo_given

    !> Whether libgmsh can be loaded (this loads it); why not in `why`.
    function gmsh_available(why) result(ok)
        character(len=*), intent(out), optional :: why   !! reason when .false.
        logical :: ok
        character(kind=c_char) :: buf(MSG_LEN)
        ok = c_gmsh_available(buf, int(MSG_LEN, c_int)) /= 0
        if (present(why)) why = from_c(buf)
    end function gmsh_available

    !> Read the mesh file `path` (.msh in any version gmsh reads, or .geo meshed with the
    !> parameters h, length, width) into `msh`, then check it (mesh_check) unless
    !> check = .false. `given` (GEO_GIVEN_* bits, default GEO_GIVEN_ALL): the parameters
    !> the scene gives, set as the .geo's; one not given keeps the file's own value where
    !> it defines it, and is set (to the value passed, the scene's default) where it uses
    !> it without defining it. A .geo that uses no h is meshed with h as its largest mesh
    !> size when h is given, with its own sizes otherwise. max_elements > 0: a .geo
    !> whose element count, estimated before meshing (estimate_geo_cells), exceeds the
    !> refusal's margin times max_elements is not meshed (STAT_BAD_INPUT, naming
    !> &mesh max_elements, and &mesh h when h is given).
    !> Errors: STAT_BAD_INPUT with a one-line message starting with the path.
    subroutine read_mesh_file(path, h, length, width, msh, stat, errmsg, check, given, &
                              max_elements)
        character(len=*), intent(in) :: path                !! .msh or .geo file
        real(dp), intent(in) :: h                           !! .geo parameter h
        real(dp), intent(in) :: length                      !! .geo parameter length
        real(dp), intent(in) :: width                       !! .geo parameter width
        type(mesh_t), intent(out) :: msh                    !! mesh read
        integer, intent(out) :: stat                        !! STAT_OK, STAT_BAD_INPUT, ...
        character(len=*), intent(inout), optional :: errmsg !! one-line message naming the file
        logical, intent(in), optional :: check              !! run mesh_check (default .true.)
        integer, intent(in), optional :: given              !! GEO_GIVEN_* bits (default all)
        integer, intent(in), optional :: max_elements       !! > 0: refuse a .geo estimated larger
        character(kind=c_char) :: cmsg(MSG_LEN)
        character(len=MSG_LEN) :: msg
        character(len=:), allocatable :: p, ext
        type(c_ptr) :: handle
        integer(c_int) :: st, dim, n_groups, names_len, is_geo
        integer(c_long_long) :: nn, nc, nf, nl
        real(dp), allocatable :: xyz(:, :)
        character(kind=c_char), allocatable :: names(:)
        logical :: exists, is_dir
        integer :: ios, ist, nbytes
        integer :: bits
        real(dp) :: limit
        real(c_double) :: est(4)

        stat = STAT_OK
        p = trim(path)
        if (len(p) == 0) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'read_mesh_file: empty file name')
            return
        end if
        inquire (file=p, exist=exists, iostat=ios)
        if (ios /= 0 .or. .not. exists) then
            call raise(stat, errmsg, STAT_BAD_INPUT, p//': no such file')
            return
        end if
        inquire (file=p//'/.', exist=is_dir, iostat=ios)
        if (ios == 0 .and. is_dir) then
            call raise(stat, errmsg, STAT_BAD_INPUT, p//': is a folder, not a mesh file')
            return
        end if
        inquire (file=p, size=nbytes, iostat=ios)
        if (ios == 0 .and. nbytes == 0) then
            call raise(stat, errmsg, STAT_BAD_INPUT, p//': file is empty')
            return
        end if
        ext = lower(file_extension(p))
        select case (ext)
        case ('.msh')
            is_geo = 0
            call msh_check_counts(p, stat, errmsg)
            if (stat /= STAT_OK) return
        case ('.geo')
            is_geo = 1
            call geo_check_commands(p, stat, errmsg)
            if (stat /= STAT_OK) return
        case default
            call raise(stat, errmsg, STAT_BAD_INPUT, p//": unknown mesh file extension '"// &
                       ext//"' (a mesh file is a gmsh .msh or .geo file)")
            return
        end select

        handle = c_null_ptr
        bits = GEO_GIVEN_ALL
        if (present(given)) bits = iand(given, GEO_GIVEN_ALL)
        limit = 0.0_dp
        if (present(max_elements)) limit = real(max(0, max_elements), dp)
        st = c_gmsh_read(p//c_null_char, [h, length, width, real(bits, dp), limit], is_geo, &
                         handle, est, cmsg, int(MSG_LEN, c_int))
        if (st == 5) then
            call raise(stat, errmsg, STAT_BAD_INPUT, p//': '//too_large_text(est, &
                       int(limit), '&mesh max_elements', &
                       merge('&mesh h', '       ', iand(bits, GEO_GIVEN_H) /= 0)))
            return
        else if (st /= 0) then
            call raise(stat, errmsg, merge(STAT_BAD_INPUT, STAT_INTERNAL, st == 2), from_c(cmsg))
            return
        end if
        call c_gmsh_sizes(handle, dim, nn, nc, nf, n_groups, names_len)
        call c_gmsh_lower_size(handle, nl)
        if (max(nn, nc, nf, nl) > huge(1)) then
            call c_gmsh_free(handle)
            call raise(stat, errmsg, STAT_BAD_INPUT, p//': too many nodes or elements')
            return
        end if
        msh%dim = dim
        msh%n_nodes = int(nn)
        msh%n_cells = int(nc)
        msh%n_facets = int(nf)
        msh%n_groups = n_groups
        msh%n_lower = int(nl)
        allocate (xyz(3, nn), msh%cells(dim + 1, nc), msh%cell_group(nc), msh%facets(dim, nf), &
                  msh%facet_group(nf), msh%group_dim(n_groups), names(max(1, names_len)), &
                  msh%lower_nodes(nl), msh%lower_group(nl), stat=ist)
        if (ist /= 0) then
            call c_gmsh_free(handle)
            call raise(stat, errmsg, STAT_INTERNAL, p//': out of memory')
            return
        end if
        call c_gmsh_arrays(handle, xyz, msh%cells, msh%cell_group, msh%facets, &
                           msh%facet_group, msh%group_dim, names)
        call c_gmsh_lower_arrays(handle, msh%lower_nodes, msh%lower_group)
        call c_gmsh_free(handle)

        call set_names(p, names(1:names_len), msh, stat, errmsg)
        if (stat /= STAT_OK) return
        call set_coordinates(p, xyz, msh, stat, errmsg)
        if (stat /= STAT_OK) return
        if (present(check)) then
            if (.not. check) return
        end if
        msg = ''
        call mesh_check(msh, ios, msg)
        if (ios /= STAT_OK) call raise(stat, errmsg, ios, p//': '//trim(msg))
    end subroutine read_mesh_file

    !> The element count of the .geo `path` estimated before meshing, as read_mesh_file
    !> would mesh it with these parameters: est = (estimate, measure, size, margin), with
    !> estimate = -1 where none can be made (gmsh_shim.c, geo_estimate; docs/scenes.md).
    !> Errors: STAT_BAD_INPUT (gmsh cannot read the file) with a message naming it.
    subroutine estimate_geo_cells(path, h, length, width, given, est, stat, errmsg)
        character(len=*), intent(in) :: path                !! .geo file
        real(dp), intent(in) :: h                           !! .geo parameter h
        real(dp), intent(in) :: length                      !! .geo parameter length
        real(dp), intent(in) :: width                       !! .geo parameter width
        integer, intent(in) :: given                        !! GEO_GIVEN_* bits (read_mesh_file)
        real(dp), intent(out) :: est(4)                     !! estimate, measure, size, margin
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! one-line message naming the file
        character(kind=c_char) :: cmsg(MSG_LEN)
        real(c_double) :: cest(4)
        integer(c_int) :: st
        stat = STAT_OK
        call geo_check_commands(trim(path), stat, errmsg)
        if (stat /= STAT_OK) return
        st = c_gmsh_estimate(trim(path)//c_null_char, &
                             [h, length, width, real(iand(given, GEO_GIVEN_ALL), dp)], cest, &
                             cmsg, int(MSG_LEN, c_int))
        est = cest
        if (st /= 0) call raise(stat, errmsg, STAT_BAD_INPUT, from_c(cmsg))
    end subroutine estimate_geo_cells

    !> Refuse a .geo with one of gmsh's commands that end, stall or escape the process
    !> (STAT_BAD_INPUT naming the file and the command): `Exit` ends the whole process,
    !> the run and a caller's Python alike, with its own status and no word; `Sleep`
    !> stalls it (once per parse, and a .geo is parsed more than once); `SystemCall`,
    !> `System`, `NonBlockingSystemCall` and `OnelabRun` start other programs. Refused
    !> too are the commands that write to disk wherever the file says, outside the run's
    !> output folder, which a geometry given to a simulation has no reason to do and
    !> which would overwrite a user's file, or append to it at every parse: `Print`,
    !> `Save` (also `Save View[i]`), `CreateDir`, `Printf(...) > file` and `>> file`,
    !> and `Plugin(name).Run` of the plugins that write files (refused_command; gmsh
    !> 4.15 has no command that deletes a file). `Printf` to the terminal passes.
    !> `Abort` ends only gmsh's parse (the file's geometry up to it is meshed) and is
    !> left to gmsh. The scan is of the text without its
    !> comments and strings ("..." and '...'); a command is the whole name, not followed
    !> by an assignment or an index (a variable of that name, `System = 1;`, passes). A
    !> file it cannot read passes (gmsh's read says why). The files gmsh parses along
    !> with it are scanned the same way (scan_geo): those it names with `Include` or
    !> `Merge`, and the options file gmsh merges after each file it merges.
    subroutine geo_check_commands(path, stat, errmsg)
        character(len=*), intent(in) :: path                !! .geo file
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! one line naming the file
        character(len=:), allocatable :: seen
        seen = achar(0)
        call scan_geo(path, path, GEO_TOP, 0, seen, stat, errmsg)
    end subroutine geo_check_commands

    !> The scan of geo_check_commands of the file `path`, reached from the top-level
    !> .geo `top` at include depth `depth` as `how` (GEO_TOP, GEO_INCLUDED, GEO_MERGED),
    !> then of the files it names with `Include "file";` or `Merge "file";`, recursively.
    !> gmsh resolves a relative name against the folder of the file that names it, an
    !> absolute one as given; it parses an included file as .geo whatever its name, and
    !> merges a file (gmshMerge, MergeFile in gmsh's OpenFile.cpp) by its extension: the
    !> extensions of its other readers (merged_by_extension) are not scanned, any other
    !> (.geo, .msh, .pos, .opt, none, ...) is parsed as .geo unless its first line is a
    !> mesh or view header (geo_header_not_geo), and after each merge gmsh merges
    !> `file.opt` when it exists, parsed as .geo too. A file named by an expression
    !> (`Include StrCat(...)`, a string variable) cannot be resolved without running
    !> gmsh's parser, and a user relies on the check to keep commands out: it is refused,
    !> naming the file that holds it (no .geo in meshes/ includes or merges a file). A
    !> file already scanned the same way is not scanned again (include cycles end, a
    !> file included twice is scanned once), a file being known by its canonical path
    !> (real_path), so that 'a.geo', './a.geo', 'sub/../a.geo' or a link to it, which
    !> gmsh reads as one file (a cycle guarded by a condition meshes), are one file
    !> here too; a file nested deeper than GEO_MAX_DEPTH is refused (gmsh itself stops
    !> on a cycle without a guard when it runs out of open files, and no .geo needs so
    !> deep a nesting). A missing file passes (gmsh's read says it cannot open it).
    recursive subroutine scan_geo(path, top, how, depth, seen, stat, errmsg)
        character(len=*), intent(in) :: path                !! file to scan
        character(len=*), intent(in) :: top                 !! the top-level .geo (messages)
        integer, intent(in) :: how                          !! GEO_TOP, GEO_INCLUDED, GEO_MERGED
        integer, intent(in) :: depth                        !! files between top and path
        character(len=:), allocatable, intent(inout) :: seen !! NUL-separated keys scanned
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! one line naming the file
        character(len=:), allocatable :: buf, key, via, name, what
        integer :: i, j, k, n, q
        logical :: ok

        stat = STAT_OK
        via = ''
        name = ''
        if (path /= top) via = ' (read through Include or Merge from '//top//')'
        if (depth > GEO_MAX_DEPTH) then
            call raise(stat, errmsg, STAT_BAD_INPUT, path//': files included or merged '// &
                       'more than '//int_text(GEO_MAX_DEPTH)//' deep'//via)
            return
        end if
        ! one file however its name is written ('a.geo', './a.geo', 'sub/../a.geo', a link)
        key = achar(48 + how)//real_path(path)//achar(0)
        if (index(seen, achar(0)//key) > 0) return
        seen = seen//key
        if (how /= GEO_INCLUDED) then     ! gmsh merges path.opt after merging path
            inquire (file=path//'.opt', exist=ok, iostat=q)
            if (q == 0 .and. ok) then
                call scan_geo(path//'.opt', top, GEO_MERGED, depth + 1, seen, stat, errmsg)
                if (stat /= STAT_OK) return
            end if
            if (how == GEO_MERGED .and. merged_by_extension(file_extension(path))) return
        end if
        call read_whole_file(path, 4, buf, ok)
        if (.not. ok) return
        if (how == GEO_MERGED .and. geo_header_not_geo(buf)) return
        n = len(buf)
        what = ''      ! (gfortran's maybe-uninitialized warning otherwise)
        i = 1
        do while (i <= n)
            j = past_comment(buf, i, .true.)                    ! a comment or a string
            if (j == 0) return                                  ! (not terminated)
            if (j /= i) then
                i = j
            else if (is_name_char(buf(i:i))) then               ! a whole name
                j = i
                do while (j < n)
                    if (.not. is_name_char(buf(j + 1:j + 1))) exit
                    j = j + 1
                end do
                what = refused_command(buf(i:j), buf(j + 1:))
                if (len(what) > 0) then
                    call raise(stat, errmsg, STAT_BAD_INPUT, path//": has gmsh's "//what// &
                               ': remove it (gmsh meshes the file without it)'//via)
                    return
                end if
                if ((buf(i:j) == 'Include' .or. buf(i:j) == 'Merge' .or. &
                     buf(i:j) == 'MergeWithBoundingBox') .and. &
                    .not. names_variable(buf(j + 1:))) then
                    q = j + next_token(buf(j + 1:))
                    k = 0
                    if (q <= n) then
                        if (buf(q:q) == '"') k = index(buf(q + 1:), '"')
                    end if
                    if (k == 0) then
                        call raise(stat, errmsg, STAT_BAD_INPUT, path//": has gmsh's '"// &
                                   buf(i:j)//"' of a file not named by a string ("// &
                                   '"file.geo"), '// &
                                   'which the check of its commands cannot follow: name the'// &
                                   ' file with a string'//via)
                        return
                    end if
                    name = buf(q + 1:q + k - 1)
                    if (len(name) > 0) then
                        if (name(1:1) /= '/') name = path(1:index(path, '/', back=.true.))//name
                        call scan_geo(name, top, merge(GEO_INCLUDED, GEO_MERGED, &
                                      buf(i:j) == 'Include'), depth + 1, seen, stat, errmsg)
                        if (stat /= STAT_OK) return
                    end if
                    j = q + k
                end if
                i = j + 1
            else
                i = i + 1
            end if
        end do
    end subroutine scan_geo

    !> What the refusal of the .geo command `name`, followed by the text `rest`, says
    !> ("'Exit' command, which would end the run without a word"), '' if it is no
    !> refused command. Refused: the commands that end, stall or escape the process
    !> (Exit, Sleep, SystemCall, System, NonBlockingSystemCall, OnelabRun) and those
    !> that write to disk where the file says, outside the run's output folder (gmsh
    !> 4.15's Gmsh.y: Print and Save, of the model or of a view, CreateDir, Printf(...)
    !> followed by '>' or '>>', and Plugin(name).Run of the plugins that write files).
    !> A name followed by an assignment, an index or a member (names_variable) is a
    !> variable or an option (Print.Width), no command; Printf without '>' prints to the
    !> terminal and passes.
    pure function refused_command(name, rest) result(what)
        character(len=*), intent(in) :: name    !! a whole name of the .geo
        character(len=*), intent(in) :: rest    !! the text after it
        character(len=:), allocatable :: what
        character(len=*), parameter :: COMMANDS(9) = [character(len=21) :: 'Exit', 'Sleep', &
            'SystemCall', 'System', 'NonBlockingSystemCall', 'OnelabRun', 'Print', 'Save', &
            'CreateDir']
        character(len=*), parameter :: EFFECTS(9) = [character(len=40) :: &
            'would end the run without a word', 'would stall the run', &
            'would run a shell command', 'would run a shell command', &
            'would run a shell command', 'would run another program', &
            'would write a file', 'would write a file', 'would create a folder']
        !> gmsh 4.15's plugins whose Run writes files (their Fopen and ofstream calls).
        character(len=*), parameter :: WRITING_PLUGINS(4) = [character(len=14) :: &
            'Bubbles', 'NearToFarField', 'BoundaryAngles', 'VoroMetal']
        integer :: k, q, e
        what = ''
        if (names_variable(rest)) return
        do k = 1, size(COMMANDS)
            if (name /= trim(COMMANDS(k))) cycle
            what = "'"//trim(COMMANDS(k))//"' command, which "//trim(EFFECTS(k))
            return
        end do
        if (name == 'Printf') then      ! Printf(...) > "file" writes, >> appends
            q = next_token(rest)
            if (q > len(rest)) return
            if (rest(q:q) /= '(') return
            e = closing_parenthesis(rest(q:))
            if (e == 0) return
            q = q + e - 1
            q = q + next_token(rest(q + 1:))
            if (q > len(rest)) return
            if (rest(q:q) /= '>') return
            if (rest(q:min(len(rest), q + 1)) == '>>') then
                what = "'Printf(...) >>' command, which would append to a file at each of "// &
                       "gmsh's parses of the .geo (two or more in a run)"
            else
                what = "'Printf(...) >' command, which would write a file"
            end if
        else if (name == 'Plugin') then ! Plugin(name).Run
            q = next_token(rest)
            if (q > len(rest)) return
            if (rest(q:q) /= '(') return
            e = closing_parenthesis(rest(q:))
            if (e == 0) return
            do k = 1, size(WRITING_PLUGINS)
                if (trim(adjustl(rest(q + 1:q + e - 2))) /= trim(WRITING_PLUGINS(k))) cycle
                q = q + e - 1
                q = q + next_token(rest(q + 1:))
                if (q > len(rest)) return
                if (rest(q:q) /= '.') return
                q = q + next_token(rest(q + 1:))
                if (q + 2 > len(rest)) return
                if (rest(q:q + 2) /= 'Run') return
                if (q + 3 <= len(rest)) then
                    if (is_name_char(rest(q + 3:q + 3))) return
                end if
                what = "'Plugin("//trim(WRITING_PLUGINS(k))//").Run' command, which would "// &
                       'write a file'
                return
            end do
        end if
    end function refused_command

    !> The offset in `text`, which starts with '(', of the ')' that closes it, skipping
    !> strings and comments; 0 if none.
    pure integer function closing_parenthesis(text) result(e)
        character(len=*), intent(in) :: text    !! '(' and what follows
        integer :: i, j, depth
        e = 0
        depth = 0
        i = 1
        do while (i <= len(text))
            j = past_comment(text, i, .true.)
            if (j == 0) return
            if (j /= i) then
                i = j
            else
                if (text(i:i) == '(') depth = depth + 1
                if (text(i:i) == ')') depth = depth - 1
                if (depth == 0) then
                    e = i
                    return
                end if
                i = i + 1
            end if
        end do
    end function closing_parenthesis

    !> The offset in `rest` of its first character after blanks and comments (gmsh's
    !> lexer skips them between a command and its argument); len(rest) + 1 if none.
    pure integer function next_token(rest)
        character(len=*), intent(in) :: rest    !! the text after a name
        integer :: i, j
        i = 1
        do while (i <= len(rest))
            j = past_comment(rest, i, .false.)
            if (j == 0) exit
            if (j /= i) then
                i = j
            else if (verify(rest(i:i), ' '//achar(9)//achar(10)//achar(13)) == 0) then
                i = i + 1
            else
                next_token = i
                return
            end if
        end do
        next_token = len(rest) + 1
    end function next_token

    !> The offset in `text` just past the comment that starts at offset i (`//` to the
    !> line's end, or `/* ... */`), or with `strings` the string ("..." or '...'): i when
    !> none starts there, 0 when it is not terminated. The .geo scan, next_token and
    !> closing_parenthesis skip comments and strings as gmsh's lexer does, through it.
    pure integer function past_comment(text, i, strings) result(k)
        character(len=*), intent(in) :: text    !! the text
        integer, intent(in) :: i                !! an offset in it
        logical, intent(in) :: strings          !! strings skipped too
        integer :: j
        k = i
        if (text(i:min(len(text), i + 1)) == '//') then
            j = index(text(i:), achar(10))
            k = merge(i + j, 0, j > 0)
        else if (text(i:min(len(text), i + 1)) == '/*') then
            j = index(text(i + 2:), '*/')
            k = merge(i + j + 3, 0, j > 0)
        else if (strings .and. (text(i:i) == '"' .or. text(i:i) == "'")) then
            j = index(text(i + 1:), text(i:i))
            k = merge(i + j + 1, 0, j > 0)
        end if
    end function past_comment

    !> True for the extensions gmsh's MergeFile (gmsh 4.15) reads with a reader of its
    !> own, CAD and mesh formats, compared in these cases only, as gmsh compares them: a
    !> file merged with one of them is not parsed as .geo. Images, read only by gmsh
    !> builds with a graphical interface, are left to the scan.
    pure logical function merged_by_extension(ext)
        character(len=*), intent(in) :: ext     !! extension with its dot, '' if none
        character(len=*), parameter :: OTHER = ' .stl .STL .nii .brep .rle .brp .BRP .xao .XAO'// &
            ' .iges .IGES .igs .IGS .step .STEP .stp .STP .sat .SAT .x_t .xmt_txt .x_b'// &
            ' .xmt_bin .unv .UNV .vtk .VTK .wrl .WRL .vrml .VRML .iv .IV .mesh .MESH .off'// &
            ' .OFF .diff .DIFF .med .MED .mmed .MMED .rmed .RMED .bdf .BDF .nas .NAS .neu'// &
            ' .NEU .dat .DAT .p3d .P3D .ply2 .PLY2 .ply .PLY .geom .GEOM '
        merged_by_extension = len(ext) > 1 .and. index(ext, ' ') == 0 .and. &
                              index(OTHER, ' '//ext//' ') > 0
    end function merged_by_extension

    !> True when a merged file's first line starts as gmsh's MergeFile reads a mesh
    !> ($MeshFormat, $Comments, $NO, $ELM, $PTS, $PARA) or a view ($PostFormat, $View)
    !> instead of parsing the file as .geo.
    pure logical function geo_header_not_geo(buf)
        character(len=*), intent(in) :: buf     !! the file's bytes
        character(len=*), parameter :: HEADERS(8) = [character(len=11) :: '$PTS', '$NO', &
            '$PARA', '$ELM', '$MeshFormat', '$Comments', '$PostFormat', '$View']
        integer :: k
        geo_header_not_geo = .false.
        do k = 1, size(HEADERS)
            if (len(buf) < len_trim(HEADERS(k))) cycle
            if (buf(1:len_trim(HEADERS(k))) == trim(HEADERS(k))) geo_header_not_geo = .true.
        end do
    end function geo_header_not_geo

    !> True when the text after a name makes it a variable: an assignment (=, +=, -=,
    !> *=, /=, ++, --), an index ([ or ~{) or a member (.), after blanks.
    pure logical function names_variable(rest)
        character(len=*), intent(in) :: rest    !! the text after the name
        integer :: j
        names_variable = .false.
        j = verify(rest, ' '//achar(9)//achar(10)//achar(13))
        if (j == 0) return
        select case (rest(j:min(len(rest), j + 1)))
        case ('+=', '-=', '*=', '/=', '++', '--', '~{')
            names_variable = .true.
        case default
            names_variable = (rest(j:j) == '=' .and. rest(j:min(len(rest), j + 1)) /= '==') &
                             .or. rest(j:j) == '[' .or. rest(j:j) == '.'
        end select
    end function names_variable

    !> True for a letter, a digit or an underscore (a .geo name's characters).
    pure logical function is_name_char(c)
        character, intent(in) :: c  !! one character
        is_name_char = verify(c, 'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ'// &
                              '0123456789_') == 0
    end function is_name_char

    !> The refusal of a .geo estimated above the limit (without the path): the estimate,
    !> what it stands on and the keys that change it, one line.
    pure function too_large_text(est, limit, limit_key, h_key) result(s)
        real(dp), intent(in) :: est(4)             !! estimate, measure, size, margin
        integer, intent(in) :: limit               !! the element limit
        character(len=*), intent(in) :: limit_key  !! its key ('&mesh max_elements')
        character(len=*), intent(in) :: h_key      !! the key of the mesh size, '' if none
        character(len=:), allocatable :: s
        s = 'about '//real_text(est(1), 2)//' elements estimated before meshing (measure '// &
            real_text(est(2), 3)//' at mesh size '//real_text(est(3), 3)//'), more than '// &
            int_text(nint(est(4)))//' x '//limit_key//' = '//int_text(limit)//': not meshed'
        if (len_trim(h_key) > 0) then
            s = s//' (a larger '//trim(h_key)//' or '//limit_key//' allows it)'
        else
            s = s//' (larger mesh sizes in the file, or a larger '//limit_key//', allow it)'
        end if
    end function too_large_text

    !> Group names from the shim's newline-terminated list; no comma (Python joins with ',').
    pure subroutine set_names(path, names, msh, stat, errmsg)
        character(len=*), intent(in) :: path                !! file (messages)
        character(kind=c_char), intent(in) :: names(:)      !! names, each ended by newline
        type(mesh_t), intent(inout) :: msh                  !! gets group_name
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: g, i, start
        stat = STAT_OK
        allocate (msh%group_name(msh%n_groups))
        msh%group_name = ''
        g = 0
        start = 1
        do i = 1, size(names)
            if (names(i) /= achar(10)) cycle
            g = g + 1
            if (g > msh%n_groups) exit
            if (i - start > GROUP_NAME_LEN) then
                call raise(stat, errmsg, STAT_BAD_INPUT, path//': a physical group name is '// &
                           'longer than the limit of 64 characters')
                return
            end if
            msh%group_name(g) = transfer(names(start:i - 1), repeat(' ', i - start))
            if (index(msh%group_name(g), ',') > 0) then
                call raise(stat, errmsg, STAT_BAD_INPUT, path//": physical group name '"// &
                           trim(msh%group_name(g))//"' contains a comma")
                return
            end if
            start = i + 1
        end do
    end subroutine set_names

    !> x = the first dim coordinates; the others must be constant (a 2D mesh in a plane
    !> z = const, a 1D mesh on a line y = const, z = const).
    pure subroutine set_coordinates(path, xyz, msh, stat, errmsg)
        character(len=*), intent(in) :: path                !! file (messages)
        real(dp), intent(in) :: xyz(:, :)                   !! (3, n_nodes)
        type(mesh_t), intent(inout) :: msh                  !! gets x
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=200) :: buf
        real(dp) :: span, scale
        integer :: j, dim
        stat = STAT_OK
        dim = msh%dim
        msh%x = xyz(1:dim, :)
        if (size(xyz, 2) == 0) return
        scale = maxval(maxval(xyz, dim=2) - minval(xyz, dim=2))
        do j = dim + 1, 3
            span = maxval(xyz(j, :)) - minval(xyz(j, :))
            if (span > PLANE_TOL * scale) then
                write (buf, '(a, i0, a, a, a)') ': the mesh is ', dim, 'D but its ', &
                    trim(merge('y', 'z', j == 2)), ' coordinates are not constant'
                if (dim == 1) buf = trim(buf)//' (a 2D geometry saved without triangles:'// &
                    ' meshed with gmsh -1 instead of -2, or no Physical Surface?)'
                if (dim == 2) buf = trim(buf)//' (a 3D geometry saved without tetrahedra:'// &
                    ' meshed with gmsh -2 instead of -3, or no Physical Volume?)'
                call raise(stat, errmsg, STAT_BAD_INPUT, path//trim(buf))
                return
            end if
        end do
    end subroutine set_coordinates

    !> The extension of `path` ('.msh'), '' if none: what decides how a mesh file is read
    !> (a .geo is meshed at the run's h, a .msh is read as it is).
    pure function file_extension(path) result(ext)
        character(len=*), intent(in) :: path   !! file name
        character(len=:), allocatable :: ext
        integer :: i
        i = index(path, '.', back=.true.)
        if (i == 0 .or. index(path(max(i, 1):), '/') > 0) then
            ext = ''
        else
            ext = path(i:)
        end if
    end function file_extension

    !> Why a mesh is refused that has an entity of a physical group without elements
    !> (without the path in front): entity `d` (0 point ... 3 volume) `tag` of group
    !> `group`. `cells_dim` > 0: read from a mesh file whose cells have that dimension;
    !> 0: a .geo meshed in-process that gmsh could not mesh. The reader's own wording,
    !> which python/dyncontact/mesh_io.py gives too (for the .geo it meshes).
    function unmeshed_text(d, tag, group, cells_dim) result(s)
        integer, intent(in) :: d                   !! the entity's dimension, 0..3
        integer, intent(in) :: tag                 !! its gmsh tag
        character(len=*), intent(in) :: group      !! its (first) physical group's name
        integer, intent(in) :: cells_dim           !! the file's cells' dimension; 0: a .geo
        character(len=:), allocatable :: s
        character(kind=c_char) :: buf(MSG_LEN)
        call c_unmeshed_text(int(d, c_int), int(tag, c_int), trim(group)//c_null_char, &
                             int(cells_dim, c_int), merge(1_c_int, 0_c_int, cells_dim > 0), &
                             buf, int(MSG_LEN, c_int))
        s = from_c(buf)
    end function unmeshed_text

    !> Fortran text of a NUL-terminated C buffer.
    pure function from_c(buf) result(s)
        character(kind=c_char), intent(in) :: buf(:)   !! C string
        character(len=:), allocatable :: s
        integer :: n
        n = 0
        do while (n < size(buf))
            if (buf(n + 1) == c_null_char) exit
            n = n + 1
        end do
        allocate (character(len=n) :: s)
        s = transfer(buf(1:n), s)
    end function from_c
end module gmsh_mesh
