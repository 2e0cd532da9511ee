!> Reader for gmsh .msh 4.1 ASCII files (nodes, segments/triangles, boundary
!> facets, physical names).
!>
!> Conventions (shared with python/dyncontact/mesh_io.py):
!> - nodes are renumbered 1..n in increasing order of their gmsh tags;
!> - groups are the physical groups in the order of $PhysicalNames, then the
!>   unnamed ones (named by their tag, e.g. '7') in order of first use in $Entities;
!> - cells (elements of the mesh dimension) keep the file order; a cell gets the
!>   first physical group of its entity, 0 if the entity has none;
!> - facets (elements of dimension dim-1) keep the file order and are stored
!>   once per physical group of their entity (in the entity's order); facets of
!>   entities without a physical group are dropped, and so are points in 2D.
module gmsh_reader
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use, intrinsic :: iso_fortran_env, only: iostat_end, iostat_eor
    use kinds, only: dp, i8
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_INTERNAL, raise, MSG_LEN
    use mesh, only: mesh_t, mesh_check, GROUP_NAME_LEN
    implicit none
    private
    public :: read_gmsh

    !> Relative tolerance of the test that dropped coordinates are constant.
    real(dp), parameter :: PLANE_TOL = 1.0e-10_dp

    !> Characters of offending text quoted in messages.
    integer, parameter :: QUOTE_LEN = 40

    !> A line-oriented token stream over the .msh file.
    type :: stream_t
        integer :: unit = -1                          !! open unit
        character(len=:), allocatable :: path         !! file name (for messages)
        character(len=:), allocatable :: line         !! current line
        character(len=:), allocatable :: section      !! current section ('' at top level)
        integer :: pos = 1                            !! next character of line
        integer :: lineno = 0                         !! current line number
    end type stream_t

    !> The file's contents before they are turned into a mesh_t.
    type :: raw_t
        ! $PhysicalNames
        integer :: n_names = 0
        integer, allocatable :: name_dim(:), name_tag(:)
        character(len=GROUP_NAME_LEN), allocatable :: name_str(:)
        ! $Entities: entity e has physical tags phys(phys_first(e) : phys_first(e+1)-1)
        integer :: n_ent = 0
        integer, allocatable :: ent_dim(:), ent_tag(:), phys_first(:), phys(:)
        ! $Nodes
        integer :: n_nodes = 0
        integer(i8), allocatable :: node_tag(:)
        real(dp), allocatable :: xyz(:, :)
        ! $Elements: block b holds elements blk_first(b) : blk_first(b+1)-1
        integer :: n_blk = 0, n_elem = 0
        integer, allocatable :: blk_dim(:), blk_ent(:), blk_type(:), blk_first(:)
        integer(i8), allocatable :: elem_tag(:), elem_node(:, :)
        ! which sections were read
        logical :: has_format = .false., has_names = .false., has_entities = .false.
        logical :: has_nodes = .false., has_elements = .false.
    end type raw_t

contains

    !> Read `path` into `msh`. The mesh dimension is the highest element dimension
    !> present (1: segments, 2: triangles). Errors (STAT_BAD_INPUT, message starts
    !> with the path): missing/unreadable file, binary or non-4.1 format, missing
    !> sections, unsupported element types.
    subroutine read_gmsh(path, msh, stat, errmsg)
        character(len=*), intent(in) :: path                !! .msh file
        type(mesh_t), intent(out) :: msh                    !! mesh read
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! one-line message naming the file
        type(stream_t) :: s
        type(raw_t) :: raw
        character(len=MSG_LEN) :: msg
        logical :: exists
        integer :: ios

        stat = STAT_OK
        s%path = trim(path)
        s%section = ''
        if (len_trim(path) == 0) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'read_gmsh: empty file name')
            return
        end if
        inquire (file=s%path, exist=exists, iostat=ios)
        if (ios /= 0 .or. .not. exists) then
            call raise(stat, errmsg, STAT_BAD_INPUT, s%path//': no such file')
            return
        end if
        open (newunit=s%unit, file=s%path, status='old', action='read', form='formatted', &
              access='sequential', iostat=ios, iomsg=msg)
        if (ios /= 0) then
            call raise(stat, errmsg, STAT_BAD_INPUT, s%path//': cannot open: '//trim(msg))
            return
        end if
        call read_sections(s, raw, stat, errmsg)
        close (s%unit, iostat=ios)
        if (stat /= STAT_OK) return
        call build_mesh(s%path, raw, msh, stat, errmsg)
        if (stat /= STAT_OK) return
        msg = ''
        call mesh_check(msh, ios, msg)
        if (ios /= STAT_OK) call raise(stat, errmsg, ios, s%path//': '//trim(msg))
    end subroutine read_gmsh

    ! ------------------------------------------------------------------ sections

    !> Read all sections of the file into `raw`.
    subroutine read_sections(s, raw, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! open stream
        type(raw_t), intent(inout) :: raw                   !! file contents
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=:), allocatable :: tok
        logical :: ok, first

        stat = STAT_OK
        first = .true.
        do
            call read_line(s, ok, stat, errmsg)
            if (stat /= STAT_OK) return
            if (.not. ok) exit
            if (len_trim(s%line) == 0) cycle
            call line_token(s, tok)
            if (first) then
                if (tok /= '$MeshFormat') then
                    call raise(stat, errmsg, STAT_BAD_INPUT, s%path// &
                               ': not a gmsh .msh file (it does not start with $MeshFormat: ' &
                               //quoted(s%line)//')')
                    return
                end if
                first = .false.
            end if
            if (tok(1:1) /= '$' .or. index(tok, '$End') == 1) then
                call fail(s, 'unexpected text outside a section: '//quoted(s%line), stat, errmsg)
                return
            end if
            s%section = tok
            select case (tok)
            case ('$MeshFormat')
                call read_format(s, raw, stat, errmsg)
            case ('$PhysicalNames')
                call once(raw%has_names)
                if (stat == STAT_OK) call read_names(s, raw, stat, errmsg)
            case ('$Entities')
                call once(raw%has_entities)
                if (stat == STAT_OK) call read_entities(s, raw, stat, errmsg)
            case ('$Nodes')
                call once(raw%has_nodes)
                if (stat == STAT_OK) call read_nodes(s, raw, stat, errmsg)
            case ('$Elements')
                call once(raw%has_elements)
                if (stat == STAT_OK) call read_elements(s, raw, stat, errmsg)
            case ('$PartitionedEntities')
                call fail(s, 'partitioned meshes are not supported', stat, errmsg)
            case default
                call skip_section(s, stat, errmsg)
            end select
            if (stat /= STAT_OK) return
            s%section = ''
        end do

        if (first) then
            call raise(stat, errmsg, STAT_BAD_INPUT, &
                       s%path//': file is empty (or not a regular file)')
        else if (.not. raw%has_nodes) then
            call raise(stat, errmsg, STAT_BAD_INPUT, s%path//': missing section $Nodes')
        else if (.not. raw%has_elements) then
            call raise(stat, errmsg, STAT_BAD_INPUT, s%path//': missing section $Elements')
        else if (.not. raw%has_entities) then
            call raise(stat, errmsg, STAT_BAD_INPUT, s%path//': missing section $Entities')
        end if

    contains

        !> A section may appear once.
        subroutine once(seen)
            logical, intent(inout) :: seen   !! whether the section was read already
            if (seen) then
                call fail(s, 'section '//s%section//' appears twice', stat, errmsg)
            end if
            seen = .true.
        end subroutine once
    end subroutine read_sections

    !> $MeshFormat: version 4.1, ASCII.
    subroutine read_format(s, raw, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream after '$MeshFormat'
        type(raw_t), intent(inout) :: raw                   !! file contents
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=:), allocatable :: version
        integer(i8) :: file_type, data_size

        if (raw%has_format) then
            call fail(s, 'section $MeshFormat appears twice', stat, errmsg)
            return
        end if
        raw%has_format = .true.
        call next_token(s, version, stat, errmsg)
        if (stat /= STAT_OK) return
        call get_int(s, 'file type', file_type, stat, errmsg)
        if (stat /= STAT_OK) return
        if (file_type == 1) then
            call fail(s, 'binary .msh files are not supported: save it as ASCII (gmsh option '// &
                      'Mesh.Binary = 0, format msh 4.1)', stat, errmsg)
            return
        end if
        if (version /= '4.1') then
            call fail(s, 'gmsh format version '//quoted(version)//' is not supported: save it '// &
                      'as msh 4.1 ASCII (gmsh -format msh41, or Mesh.MshFileVersion = 4.1)', &
                      stat, errmsg)
            return
        end if
        if (file_type /= 0) then
            call fail(s, 'unknown file type in $MeshFormat (0 = ASCII expected)', stat, errmsg)
            return
        end if
        call get_int(s, 'data size', data_size, stat, errmsg)
        if (stat /= STAT_OK) return
        call end_section(s, stat, errmsg)
    end subroutine read_format

    !> $PhysicalNames: dim tag "name" per line.
    subroutine read_names(s, raw, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream after '$PhysicalNames'
        type(raw_t), intent(inout) :: raw                   !! file contents
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: n, k, q1, q2, j
        character(len=:), allocatable :: rest

        call get_count(s, 'number of physical names', n, stat, errmsg)
        if (stat /= STAT_OK) return
        allocate (raw%name_dim(n), raw%name_tag(n), raw%name_str(n))
        raw%n_names = n
        do k = 1, n
            call get_small_int(s, 'physical group dimension', 0, 3, raw%name_dim(k), stat, errmsg)
            if (stat /= STAT_OK) return
            call get_small_int(s, 'physical tag', -huge(1), huge(1), raw%name_tag(k), stat, errmsg)
            if (stat /= STAT_OK) return
            rest = s%line(s%pos:)
            s%pos = len(s%line) + 1
            q1 = index(rest, '"')
            q2 = index(rest, '"', back=.true.)
            if (q1 == 0 .or. q2 <= q1) then
                call fail(s, 'physical name not in double quotes: '//quoted(rest), stat, errmsg)
                return
            end if
            if (len_trim(rest(q2 + 1:)) > 0) then
                call fail(s, 'unexpected text after a physical name: '//quoted(rest), stat, errmsg)
                return
            end if
            rest = rest(q1 + 1:q2 - 1)
            if (len(rest) > GROUP_NAME_LEN) then
                call fail(s, 'physical name '//quoted(rest)//' is too long', stat, errmsg)
                return
            end if
            if (index(rest, ',') > 0) then
                call fail(s, 'physical name '//quoted(rest)//' contains a comma', stat, errmsg)
                return
            end if
            raw%name_str(k) = rest
            do j = 1, k - 1
                if (raw%name_dim(j) == raw%name_dim(k) .and. &
                    raw%name_tag(j) == raw%name_tag(k)) then
                    call fail(s, 'physical group named twice: '//quoted(rest), stat, errmsg)
                    return
                end if
            end do
        end do
        call end_section(s, stat, errmsg)
    end subroutine read_names

    !> $Entities: the physical tags of every point, curve, surface and volume.
    subroutine read_entities(s, raw, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream after '$Entities'
        type(raw_t), intent(inout) :: raw                   !! file contents
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: counts(0:3), d, e, k, np, nb, n_phys
        integer(i8) :: skip
        real(dp) :: r
        integer, allocatable :: tmp(:)

        do d = 0, 3
            call get_count(s, 'number of entities', counts(d), stat, errmsg)
            if (stat /= STAT_OK) return
        end do
        raw%n_ent = sum(counts)
        allocate (raw%ent_dim(raw%n_ent), raw%ent_tag(raw%n_ent), raw%phys_first(raw%n_ent + 1))
        allocate (raw%phys(16))
        n_phys = 0
        e = 0
        do d = 0, 3
            do k = 1, counts(d)
                e = e + 1
                raw%ent_dim(e) = d
                raw%phys_first(e) = n_phys + 1
                call get_small_int(s, 'entity tag', -huge(1), huge(1), raw%ent_tag(e), stat, errmsg)
                if (stat /= STAT_OK) return
                ! point: X Y Z; others: bounding box
                do np = 1, merge(3, 6, d == 0)
                    call get_real(s, 'entity coordinate', r, stat, errmsg)
                    if (stat /= STAT_OK) return
                end do
                call get_count(s, 'number of physical tags', np, stat, errmsg)
                if (stat /= STAT_OK) return
                if (n_phys + np > size(raw%phys)) then
                    allocate (tmp(2 * (n_phys + np)))
                    tmp(1:n_phys) = raw%phys(1:n_phys)
                    call move_alloc(tmp, raw%phys)
                end if
                do nb = 1, np
                    call get_small_int(s, 'physical tag', -huge(1), huge(1), &
                                       raw%phys(n_phys + 1), stat, errmsg)
                    if (stat /= STAT_OK) return
                    ! a tag listed twice counts once
                    if (.not. any(raw%phys(raw%phys_first(e):n_phys) == raw%phys(n_phys + 1))) &
                        n_phys = n_phys + 1
                end do
                if (d > 0) then
                    call get_count(s, 'number of bounding entities', nb, stat, errmsg)
                    if (stat /= STAT_OK) return
                    do np = 1, nb
                        call get_int(s, 'bounding entity tag', skip, stat, errmsg)
                        if (stat /= STAT_OK) return
                    end do
                end if
            end do
        end do
        raw%phys_first(raw%n_ent + 1) = n_phys + 1
        call end_section(s, stat, errmsg)
    end subroutine read_entities

    !> $Nodes: entity blocks of node tags then coordinates.
    subroutine read_nodes(s, raw, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream after '$Nodes'
        type(raw_t), intent(inout) :: raw                   !! file contents
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: n_blocks, n, b, ent_dim, param, nb, k, j, ist
        integer(i8) :: tmin, tmax
        real(dp) :: r
        character(len=120) :: buf

        call get_count(s, 'number of node blocks', n_blocks, stat, errmsg)
        if (stat /= STAT_OK) return
        call get_count(s, 'number of nodes', n, stat, errmsg)
        if (stat /= STAT_OK) return
        call get_int(s, 'smallest node tag', tmin, stat, errmsg)
        if (stat /= STAT_OK) return
        call get_int(s, 'largest node tag', tmax, stat, errmsg)
        if (stat /= STAT_OK) return
        allocate (raw%node_tag(n), raw%xyz(3, n), stat=ist)
        if (ist /= 0) then
            call fail(s, 'bad count: cannot allocate the announced number of nodes', stat, errmsg)
            return
        end if
        raw%n_nodes = n
        k = 0
        do b = 1, n_blocks
            call get_small_int(s, 'entity dimension', 0, 3, ent_dim, stat, errmsg)
            if (stat /= STAT_OK) return
            call get_small_int(s, 'entity tag', -huge(1), huge(1), j, stat, errmsg)
            if (stat /= STAT_OK) return
            call get_small_int(s, 'parametric flag', 0, 1, param, stat, errmsg)
            if (stat /= STAT_OK) return
            call get_count(s, 'number of nodes in block', nb, stat, errmsg)
            if (stat /= STAT_OK) return
            if (nb > n - k) then
                write (buf, '(a, i0, a)') 'bad count: the node blocks hold more than the ', n, &
                    ' nodes announced'
                call fail(s, trim(buf), stat, errmsg)
                return
            end if
            do j = k + 1, k + nb
                call get_int(s, 'node tag', raw%node_tag(j), stat, errmsg)
                if (stat /= STAT_OK) return
            end do
            do j = k + 1, k + nb
                call get_real(s, 'node x', raw%xyz(1, j), stat, errmsg)
                if (stat == STAT_OK) call get_real(s, 'node y', raw%xyz(2, j), stat, errmsg)
                if (stat == STAT_OK) call get_real(s, 'node z', raw%xyz(3, j), stat, errmsg)
                if (stat /= STAT_OK) return
                do ist = 1, param * ent_dim
                    call get_real(s, 'node parametric coordinate', r, stat, errmsg)
                    if (stat /= STAT_OK) return
                end do
            end do
            k = k + nb
        end do
        if (k /= n) then
            write (buf, '(a, i0, a, i0)') 'bad count: ', n, &
                ' nodes announced, the blocks hold ', k
            call fail(s, trim(buf), stat, errmsg)
            return
        end if
        call end_section(s, stat, errmsg)
    end subroutine read_nodes

    !> $Elements: entity blocks of points, lines and triangles.
    subroutine read_elements(s, raw, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream after '$Elements'
        type(raw_t), intent(inout) :: raw                   !! file contents
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: n_blocks, n, b, k, j, i, nb, nv, etype, edim, ist
        integer(i8) :: tmin, tmax
        character(len=120) :: buf

        call get_count(s, 'number of element blocks', n_blocks, stat, errmsg)
        if (stat /= STAT_OK) return
        call get_count(s, 'number of elements', n, stat, errmsg)
        if (stat /= STAT_OK) return
        call get_int(s, 'smallest element tag', tmin, stat, errmsg)
        if (stat /= STAT_OK) return
        call get_int(s, 'largest element tag', tmax, stat, errmsg)
        if (stat /= STAT_OK) return
        allocate (raw%blk_dim(n_blocks), raw%blk_ent(n_blocks), raw%blk_type(n_blocks), &
                  raw%blk_first(n_blocks + 1), raw%elem_tag(n), raw%elem_node(3, n), stat=ist)
        if (ist /= 0) then
            call fail(s, 'bad count: cannot allocate the announced number of elements', &
                      stat, errmsg)
            return
        end if
        raw%n_blk = n_blocks
        raw%n_elem = n
        raw%elem_node = 0
        k = 0
        do b = 1, n_blocks
            raw%blk_first(b) = k + 1
            call get_small_int(s, 'entity dimension', 0, 3, raw%blk_dim(b), stat, errmsg)
            if (stat /= STAT_OK) return
            call get_small_int(s, 'entity tag', -huge(1), huge(1), raw%blk_ent(b), stat, errmsg)
            if (stat /= STAT_OK) return
            call get_small_int(s, 'element type', -huge(1), huge(1), etype, stat, errmsg)
            if (stat /= STAT_OK) return
            select case (etype)
            case (15)
                edim = 0; nv = 1
            case (1)
                edim = 1; nv = 2
            case (2)
                edim = 2; nv = 3
            case (4)
                call fail(s, 'tetrahedra (element type 4): 3D meshes are not supported yet', &
                          stat, errmsg)
                return
            case default
                write (buf, '(a, i0, a)') 'element type ', etype, ' is not supported '// &
                    '(only 15 point, 1 line, 2 triangle: first-order simplices)'
                call fail(s, trim(buf), stat, errmsg)
                return
            end select
            if (edim /= raw%blk_dim(b)) then
                write (buf, '(a, i0, a, i0)') 'element type ', etype, &
                    ' in a block of entity dimension ', raw%blk_dim(b)
                call fail(s, trim(buf), stat, errmsg)
                return
            end if
            raw%blk_type(b) = etype
            call get_count(s, 'number of elements in block', nb, stat, errmsg)
            if (stat /= STAT_OK) return
            if (nb > n - k) then
                write (buf, '(a, i0, a)') 'bad count: the element blocks hold more than the ', n, &
                    ' elements announced'
                call fail(s, trim(buf), stat, errmsg)
                return
            end if
            do j = k + 1, k + nb
                call get_int(s, 'element tag', raw%elem_tag(j), stat, errmsg)
                if (stat /= STAT_OK) return
                do i = 1, nv
                    call get_int(s, 'element node tag', raw%elem_node(i, j), stat, errmsg)
                    if (stat /= STAT_OK) return
                end do
            end do
            k = k + nb
        end do
        raw%blk_first(n_blocks + 1) = k + 1
        if (k /= n) then
            write (buf, '(a, i0, a, i0)') 'bad count: ', n, &
                ' elements announced, the blocks hold ', k
            call fail(s, trim(buf), stat, errmsg)
            return
        end if
        call end_section(s, stat, errmsg)
    end subroutine read_elements

    !> Skip an unknown section up to its $End line.
    subroutine skip_section(s, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream after '$Name'
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=:), allocatable :: tok
        logical :: ok
        do
            call read_line(s, ok, stat, errmsg)
            if (stat /= STAT_OK) return
            if (.not. ok) then
                call raise(stat, errmsg, STAT_BAD_INPUT, s%path//': unexpected end of file in '// &
                           s%section//' (truncated?)')
                return
            end if
            call line_token(s, tok)
            if (tok == '$End'//s%section(2:)) return
        end do
    end subroutine skip_section

    !> The next token must close the current section.
    subroutine end_section(s, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=:), allocatable :: tok
        call next_token(s, tok, stat, errmsg)
        if (stat /= STAT_OK) return
        if (tok /= '$End'//s%section(2:)) then
            call fail(s, 'bad count or extra data: expected $End'//s%section(2:)//', got '// &
                      quoted(tok), stat, errmsg)
            return
        end if
        s%pos = len(s%line) + 1
    end subroutine end_section

    ! ------------------------------------------------------------------ mesh

    !> Turn the raw contents into a mesh (see the module notes for the conventions).
    subroutine build_mesh(path, raw, msh, stat, errmsg)
        character(len=*), intent(in) :: path                !! file name for messages
        type(raw_t), intent(inout) :: raw                   !! file contents
        type(mesh_t), intent(inout) :: msh                  !! the mesh
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        integer, allocatable :: perm(:), ent_group(:), blk_e(:)
        integer(i8), allocatable :: sorted_tag(:)
        character(len=200) :: buf
        integer :: dim, b, e, j, k, v, c, f, ist, idx
        real(dp) :: span, scale

        stat = STAT_OK
        ! groups and the group index of every physical tag of every entity
        call build_groups(raw, msh, ent_group)

        ! nodes: renumber by increasing tag
        call sort_index(raw%node_tag, perm)
        allocate (sorted_tag(raw%n_nodes))
        sorted_tag = raw%node_tag(perm)
        do j = 2, raw%n_nodes
            if (sorted_tag(j) == sorted_tag(j - 1)) then
                write (buf, '(a, i0, a)') ': node tag ', sorted_tag(j), ' appears twice in $Nodes'
                call raise(stat, errmsg, STAT_BAD_INPUT, path//trim(buf))
                return
            end if
        end do

        ! dimension: highest element dimension present
        dim = 0
        do b = 1, raw%n_blk
            if (raw%blk_first(b + 1) > raw%blk_first(b)) dim = max(dim, raw%blk_dim(b))
        end do
        if (dim < 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, &
                       path//': no segments or triangles in $Elements')
            return
        end if

        ! entity of every block
        allocate (blk_e(raw%n_blk))
        do b = 1, raw%n_blk
            blk_e(b) = 0
            do e = 1, raw%n_ent
                if (raw%ent_dim(e) == raw%blk_dim(b) .and. raw%ent_tag(e) == raw%blk_ent(b)) then
                    blk_e(b) = e
                    exit
                end if
            end do
            if (blk_e(b) == 0 .and. raw%blk_first(b + 1) > raw%blk_first(b)) then
                write (buf, '(a, i0, a, i0, a)') ': an element block refers to entity (dim ', &
                    raw%blk_dim(b), ', tag ', raw%blk_ent(b), ') missing from $Entities'
                call raise(stat, errmsg, STAT_BAD_INPUT, path//trim(buf))
                return
            end if
        end do

        ! counts
        msh%dim = dim
        msh%n_nodes = raw%n_nodes
        msh%n_cells = 0
        msh%n_facets = 0
        do b = 1, raw%n_blk
            j = raw%blk_first(b + 1) - raw%blk_first(b)
            if (j == 0) cycle
            e = blk_e(b)
            if (raw%blk_dim(b) == dim) msh%n_cells = msh%n_cells + j
            if (raw%blk_dim(b) == dim - 1) &
                msh%n_facets = msh%n_facets + j * (raw%phys_first(e + 1) - raw%phys_first(e))
        end do
        allocate (msh%x(dim, msh%n_nodes), msh%cells(dim + 1, msh%n_cells), &
                  msh%cell_group(msh%n_cells), msh%facets(dim, msh%n_facets), &
                  msh%facet_group(msh%n_facets), stat=ist)
        if (ist /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, path//': out of memory')
            return
        end if

        ! coordinates: the first dim ones; the others must be constant
        msh%x = raw%xyz(1:dim, perm)
        if (raw%n_nodes > 0) then
            scale = maxval(maxval(raw%xyz, dim=2) - minval(raw%xyz, dim=2))
            do j = dim + 1, 3
                span = maxval(raw%xyz(j, :)) - minval(raw%xyz(j, :))
                if (span > PLANE_TOL * scale) then
                    write (buf, '(a, i0, a, a, a)') ': the mesh is ', dim, 'D but its ', &
                        trim(merge('y', 'z', j == 2)), ' coordinates are not constant'
                    if (dim == 1) buf = trim(buf)//' (a 2D geometry saved without triangles:'// &
                        ' no Physical Surface?)'
                    call raise(stat, errmsg, STAT_BAD_INPUT, path//trim(buf))
                    return
                end if
            end do
        end if

        ! cells and facets in file order
        c = 0
        f = 0
        do b = 1, raw%n_blk
            e = blk_e(b)
            if (raw%blk_dim(b) /= dim .and. raw%blk_dim(b) /= dim - 1) cycle
            do j = raw%blk_first(b), raw%blk_first(b + 1) - 1
                if (raw%blk_dim(b) == dim) then
                    c = c + 1
                    do v = 1, dim + 1
                        call node_index(raw%elem_node(v, j), j, idx)
                        if (stat /= STAT_OK) return
                        msh%cells(v, c) = idx
                    end do
                    msh%cell_group(c) = 0
                    if (raw%phys_first(e + 1) > raw%phys_first(e)) &
                        msh%cell_group(c) = ent_group(raw%phys_first(e))
                else
                    do k = raw%phys_first(e), raw%phys_first(e + 1) - 1
                        f = f + 1
                        do v = 1, dim
                            call node_index(raw%elem_node(v, j), j, idx)
                            if (stat /= STAT_OK) return
                            msh%facets(v, f) = idx
                        end do
                        msh%facet_group(f) = ent_group(k)
                    end do
                end if
            end do
        end do
    contains

        !> Mesh node number of node tag `tag` of element `j`.
        subroutine node_index(tag, j, idx)
            integer(i8), intent(in) :: tag   !! gmsh node tag
            integer, intent(in) :: j         !! element (raw index) that uses it
            integer, intent(out) :: idx      !! 1..n_nodes
            integer :: lo, hi, mid
            lo = 1
            hi = raw%n_nodes
            idx = 0
            do while (lo <= hi)
                mid = lo + (hi - lo) / 2
                if (sorted_tag(mid) == tag) then
                    idx = mid
                    return
                else if (sorted_tag(mid) < tag) then
                    lo = mid + 1
                else
                    hi = mid - 1
                end if
            end do
            write (buf, '(a, i0, a, i0, a)') ': element ', raw%elem_tag(j), &
                ' refers to unknown node ', tag, ' (not in $Nodes)'
            call raise(stat, errmsg, STAT_BAD_INPUT, path//trim(buf))
        end subroutine node_index
    end subroutine build_mesh

    !> Groups: named ones in $PhysicalNames order, then unnamed physical tags of
    !> the entities in order of first use. ent_group(k) is the group of raw%phys(k).
    subroutine build_groups(raw, msh, ent_group)
        type(raw_t), intent(in) :: raw                      !! file contents
        type(mesh_t), intent(inout) :: msh                  !! gets n_groups, group_name, group_dim
        integer, allocatable, intent(out) :: ent_group(:)   !! group of each entity physical tag
        integer, allocatable :: gdim(:), gtag(:)
        character(len=GROUP_NAME_LEN), allocatable :: gname(:)
        character(len=GROUP_NAME_LEN) :: tagname
        integer :: n, e, k, g, found

        n = raw%n_names
        allocate (gdim(n + size(raw%phys)), gtag(n + size(raw%phys)), gname(n + size(raw%phys)))
        allocate (ent_group(size(raw%phys)))
        ent_group = 0
        if (n > 0) then
            gdim(1:n) = raw%name_dim
            gtag(1:n) = raw%name_tag
            gname(1:n) = raw%name_str
        end if
        do e = 1, raw%n_ent
            do k = raw%phys_first(e), raw%phys_first(e + 1) - 1
                found = 0
                do g = 1, n
                    if (gdim(g) == raw%ent_dim(e) .and. gtag(g) == raw%phys(k)) then
                        found = g
                        exit
                    end if
                end do
                if (found == 0) then
                    n = n + 1
                    gdim(n) = raw%ent_dim(e)
                    gtag(n) = raw%phys(k)
                    write (tagname, '(i0)') raw%phys(k)
                    gname(n) = tagname
                    found = n
                end if
                ent_group(k) = found
            end do
        end do
        ! an empty name is replaced by the tag
        do g = 1, n
            if (len_trim(gname(g)) == 0) then
                write (tagname, '(i0)') gtag(g)
                gname(g) = tagname
            end if
        end do
        msh%n_groups = n
        msh%group_name = gname(1:n)
        msh%group_dim = gdim(1:n)
    end subroutine build_groups

    !> Stable merge sort: keys(perm) is non-decreasing.
    pure subroutine sort_index(keys, perm)
        integer(i8), intent(in) :: keys(:)              !! keys to sort
        integer, allocatable, intent(out) :: perm(:)    !! permutation of 1..size(keys)
        integer, allocatable :: tmp(:)
        integer :: n, width, lo, mid, hi, i, j, k
        logical :: take_left
        n = size(keys)
        allocate (perm(n), tmp(n))
        perm = [(i, i = 1, n)]
        width = 1
        do while (width < n)
            lo = 1
            do while (lo <= n)
                mid = min(lo + width, n + 1)
                hi = min(lo + 2 * width, n + 1)
                i = lo; j = mid; k = lo
                do while (k < hi)
                    ! min() keeps the indices valid: Fortran may evaluate both operands
                    take_left = i < mid
                    if (take_left .and. j < hi) &
                        take_left = keys(perm(min(i, n))) <= keys(perm(min(j, n)))
                    if (take_left) then
                        tmp(k) = perm(i); i = i + 1
                    else
                        tmp(k) = perm(j); j = j + 1
                    end if
                    k = k + 1
                end do
                lo = hi
            end do
            perm = tmp
            width = 2 * width
        end do
    end subroutine sort_index

    ! ------------------------------------------------------------------ tokens

    !> Read the next line into s%line; ok = .false. at the end of the file.
    subroutine read_line(s, ok, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream
        logical, intent(out) :: ok                          !! a line was read
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=256) :: chunk
        character(len=MSG_LEN) :: msg
        integer :: ios, sz
        logical :: any_read

        stat = STAT_OK
        ok = .true.
        any_read = .false.
        s%line = ''
        s%pos = 1
        do
            read (s%unit, '(a)', advance='no', size=sz, iostat=ios, iomsg=msg) chunk
            if (ios == 0 .or. ios == iostat_eor) then
                s%line = s%line//chunk(1:sz)
                any_read = .true.
                if (ios == iostat_eor) exit
            else if (ios == iostat_end) then
                ok = any_read .and. len(s%line) > 0
                exit
            else
                call raise(stat, errmsg, STAT_BAD_INPUT, s%path//': read error: '//trim(msg))
                ok = .false.
                return
            end if
        end do
        if (ok) s%lineno = s%lineno + 1
    end subroutine read_line

    !> First token of the current line (the line is then consumed).
    subroutine line_token(s, tok)
        type(stream_t), intent(inout) :: s              !! stream
        character(len=:), allocatable, intent(out) :: tok !! first token, '' on a blank line
        integer :: a, b
        call token_bounds(s%line, 1, a, b)
        if (a > b) then
            tok = ''
        else
            tok = s%line(a:b)
        end if
        s%pos = len(s%line) + 1
    end subroutine line_token

    !> Bounds a:b of the first token of line at or after `from` (a > b if none).
    pure subroutine token_bounds(line, from, a, b)
        character(len=*), intent(in) :: line   !! text
        integer, intent(in) :: from            !! first position to look at
        integer, intent(out) :: a              !! token start
        integer, intent(out) :: b              !! token end
        a = from
        do while (a <= len(line))
            if (.not. is_blank(line(a:a))) exit
            a = a + 1
        end do
        b = a
        do while (b <= len(line))
            if (is_blank(line(b:b))) exit
            b = b + 1
        end do
        b = b - 1
    end subroutine token_bounds

    !> Blank, tab or carriage return.
    elemental logical function is_blank(ch)
        character, intent(in) :: ch   !! one character
        is_blank = ch == ' ' .or. ch == achar(9) .or. ch == achar(13) .or. ch == achar(0)
    end function is_blank

    !> Next whitespace-separated token, reading more lines as needed.
    subroutine next_token(s, tok, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream
        character(len=:), allocatable, intent(out) :: tok   !! the token
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: a, b
        logical :: ok
        stat = STAT_OK
        do
            call token_bounds(s%line, s%pos, a, b)
            if (a <= b) exit
            call read_line(s, ok, stat, errmsg)
            if (stat /= STAT_OK) return
            if (.not. ok) then
                call raise(stat, errmsg, STAT_BAD_INPUT, s%path//': unexpected end of file in '// &
                           s%section//' (truncated?)')
                return
            end if
        end do
        tok = s%line(a:b)
        s%pos = b + 1
    end subroutine next_token

    !> Next token as a (64-bit) integer.
    subroutine get_int(s, what, val, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream
        character(len=*), intent(in) :: what                !! what is expected (for messages)
        integer(i8), intent(out) :: val                     !! the value
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=:), allocatable :: tok
        logical :: ok
        val = 0
        call next_token(s, tok, stat, errmsg)
        if (stat /= STAT_OK) return
        call parse_int(tok, val, ok)
        if (.not. ok) then
            if (tok(1:1) == '$') then
                call fail(s, 'bad count: section ends early, '//quoted(tok)//' where '// &
                          what//' expected', stat, errmsg)
            else
                call fail(s, 'expected '//what//' (an integer), got '//quoted(tok), stat, errmsg)
            end if
        end if
    end subroutine get_int

    !> Next token as an integer in [lo, hi].
    subroutine get_small_int(s, what, lo, hi, val, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream
        character(len=*), intent(in) :: what                !! what is expected (for messages)
        integer, intent(in) :: lo                           !! smallest value allowed
        integer, intent(in) :: hi                           !! largest value allowed
        integer, intent(out) :: val                         !! the value
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(i8) :: v
        character(len=80) :: buf
        val = 0
        call get_int(s, what, v, stat, errmsg)
        if (stat /= STAT_OK) return
        if (v < lo .or. v > hi) then
            write (buf, '(a, i0, a, i0, a, i0)') ' = ', v, ' is outside ', lo, '..', hi
            call fail(s, what//trim(buf), stat, errmsg)
            return
        end if
        val = int(v)
    end subroutine get_small_int

    !> Next token as a count (0 .. huge(1)).
    subroutine get_count(s, what, val, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream
        character(len=*), intent(in) :: what                !! what is expected (for messages)
        integer, intent(out) :: val                         !! the count
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(i8) :: v
        character(len=80) :: buf
        val = 0
        call get_int(s, what, v, stat, errmsg)
        if (stat /= STAT_OK) return
        if (v < 0 .or. v > huge(1)) then
            write (buf, '(a, i0)') ' = ', v
            call fail(s, 'bad count: '//what//trim(buf), stat, errmsg)
            return
        end if
        val = int(v)
    end subroutine get_count

    !> Next token as a finite real.
    subroutine get_real(s, what, val, stat, errmsg)
        type(stream_t), intent(inout) :: s                  !! stream
        character(len=*), intent(in) :: what                !! what is expected (for messages)
        real(dp), intent(out) :: val                        !! the value
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=:), allocatable :: tok
        integer :: ios
        val = 0
        call next_token(s, tok, stat, errmsg)
        if (stat /= STAT_OK) return
        ios = 1
        if (verify(tok, '0123456789+-.eEdD') == 0) read (tok, *, iostat=ios) val
        if (ios /= 0) then
            if (tok(1:1) == '$') then
                call fail(s, 'bad count: section ends early, '//quoted(tok)//' where '// &
                          what//' expected', stat, errmsg)
            else
                call fail(s, 'expected '//what//' (a number), got '//quoted(tok), stat, errmsg)
            end if
            return
        end if
        if (.not. ieee_is_finite(val)) call fail(s, what//' is not finite', stat, errmsg)
    end subroutine get_real

    !> Decimal integer with an optional sign; ok = .false. on anything else or overflow.
    pure subroutine parse_int(tok, val, ok)
        character(len=*), intent(in) :: tok   !! token
        integer(i8), intent(out) :: val       !! value
        logical, intent(out) :: ok            !! tok is an integer that fits
        integer :: i, first, d
        logical :: neg
        val = 0
        ok = .false.
        neg = tok(1:1) == '-'
        first = 1
        if (tok(1:1) == '-' .or. tok(1:1) == '+') first = 2
        if (first > len(tok)) return
        do i = first, len(tok)
            d = iachar(tok(i:i)) - iachar('0')
            if (d < 0 .or. d > 9) return
            if (val > (huge(val) - d) / 10) return
            val = 10 * val + d
        end do
        if (neg) val = -val
        ok = .true.
    end subroutine parse_int

    !> Raise STAT_BAD_INPUT with "path: line N: msg".
    subroutine fail(s, msg, stat, errmsg)
        type(stream_t), intent(in) :: s                     !! stream (path, line number)
        character(len=*), intent(in) :: msg                 !! what is wrong
        integer, intent(out) :: stat                        !! set to STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=24) :: where
        write (where, '(a, i0, a)') ': line ', s%lineno, ': '
        if (len(s%section) > 0) then
            call raise(stat, errmsg, STAT_BAD_INPUT, s%path//trim(where)//' '//s%section//': '//msg)
        else
            call raise(stat, errmsg, STAT_BAD_INPUT, s%path//trim(where)//' '//msg)
        end if
    end subroutine fail

    !> Text quoted for a message: shortened, non-printable characters as '?'.
    pure function quoted(text) result(q)
        character(len=*), intent(in) :: text   !! offending text
        character(len=:), allocatable :: q
        integer :: i, n
        n = min(len_trim(text), QUOTE_LEN)
        q = text(1:n)
        do i = 1, n
            if (iachar(q(i:i)) < 32 .or. iachar(q(i:i)) > 126) q(i:i) = '?'
        end do
        q = "'"//q//"'"
        if (len_trim(text) > QUOTE_LEN) q = q//'...'
    end function quoted
end module gmsh_reader
