!> The checkpoint file of a run (docs/scenes.md, "Checkpoint and restart"): a header of
!> 8-byte fields (magic, format version, scene hash, payload size and checksum, dofs,
!> step) and a 96-byte build identifier, then the payload the run packed. Written
!> atomically (temporary file, fsync, rename); read back only when every field of the
!> header matches the run and the payload's checksum is right, else STAT_BAD_INPUT
!> naming the file.
module checkpoint_file
    use, intrinsic :: iso_fortran_env, only: compiler_version
    use kinds, only: dp, i8
    use text, only: int_text
    use errors, only: STAT_OK, STAT_BAD_INPUT, raise
    use byte_buffer, only: byte_buffer_t
    use scene, only: scene_t, scene_to_json
    use mesh, only: mesh_t
    use os_files, only: fd_open, fd_write, fd_sync, fd_close, file_rename, file_remove, bytes_hash
    use version_info, only: DYNCONTACT_VERSION, DYNCONTACT_ISA
    implicit none
    private

    character(len=*), parameter, public :: CHECKPOINT_NAME = 'checkpoint.bin' !! file in the output folder
    character(len=8), parameter :: MAGIC = 'DYNCKPT'//achar(0)   !! first bytes of the file
    !> Layout of header and payload (2: the CG counters follow the scheme's data; 3: the
    !> column cache's layout; 4: f_n, the normal contact force, after e_theta; 5: the scene
    !> hash continues over the mesh, so that a file of 4 is refused as of another format
    !> rather than of another scene; 6: the scene hash leaves out the keys that say when
    !> to stop and dt, which the payload carries, so that a file of 5 is refused as of
    !> another format rather than misread as another scene's).
    integer(i8), parameter :: FORMAT_VERSION = 6
    integer, parameter :: BUILD_LEN = 96                          !! bytes of the build identifier
    integer, parameter :: HEADER_BYTES = 7 * 8 + BUILD_LEN        !! header size

    public :: checkpoint_scene_hash, checkpoint_mesh_hash, checkpoint_build_id, checkpoint_write, &
              checkpoint_read

contains

    !> Hash of the parsed scene's canonical text (scene_to_json) without the keys that do
    !> not change the numbers or the trace's rows: the output folder, checkpoint_every and
    !> the mesh file's name (the same file is 'm.msh' in a scene file and its absolute path
    !> in the copy dyncontact.Scene writes; the mesh it gives counts, checkpoint_mesh_hash);
    !> the keys that only say when to stop, &scheme t_end, max_steps and blowup, so that a
    !> restart with a later t_end or a raised blowup continues the run; and &scheme dt,
    !> which the payload carries as the step the run took (central's dt = 0 takes a step
    !> that divides t_end: the step, not the key, is what must be the same; compared with
    !> its own message in sim_checkpoint_load).
    function checkpoint_scene_hash(scn) result(h)
        type(scene_t), intent(in) :: scn    !! the scene as read
        integer(i8) :: h
        type(scene_t) :: copy
        copy = scn
        copy%out_dir = ''
        copy%checkpoint_every = 0
        copy%mesh_file = ''
        copy%t_end = 0.0_dp
        copy%max_steps = 0
        copy%blowup = 0.0_dp
        copy%dt = 0.0_dp
        h = bytes_hash(scene_to_json(copy), 0_i8)
    end function checkpoint_scene_hash

    !> The hash h0 (checkpoint_scene_hash) extended with the mesh the run built: node
    !> coordinates, cells, tagged facets, the nodes of point and curve groups and the
    !> groups' names. A mesh file is named in the
    !> scene, not held by it: edited between a stop and a restart (nodes moved, the same
    !> number of dofs) it makes another run, which the scene's hash alone would not see.
    function checkpoint_mesh_hash(h0, msh) result(h)
        integer(i8), intent(in) :: h0       !! hash so far (the scene's)
        type(mesh_t), intent(in) :: msh     !! the run's mesh
        integer(i8) :: h
        integer, parameter :: IB = storage_size(0) / 8, RB = storage_size(1.0_dp) / 8  !! bytes
        integer :: i
        h = bytes_hash(transfer([msh%dim, msh%n_nodes, msh%n_cells, msh%n_facets, msh%n_groups], &
                                repeat(' ', 5 * IB)), h0)
        if (msh%n_nodes > 0) h = bytes_hash(transfer(msh%x, repeat(' ', RB * size(msh%x))), h)
        if (msh%n_cells > 0) then
            h = bytes_hash(transfer(msh%cells, repeat(' ', IB * size(msh%cells))), h)
            h = bytes_hash(transfer(msh%cell_group, repeat(' ', IB * msh%n_cells)), h)
        end if
        if (msh%n_facets > 0) then
            h = bytes_hash(transfer(msh%facets, repeat(' ', IB * size(msh%facets))), h)
            h = bytes_hash(transfer(msh%facet_group, repeat(' ', IB * msh%n_facets)), h)
        end if
        if (msh%n_lower > 0) then   ! (none: the hash of a mesh without such groups, as before)
            h = bytes_hash(transfer(msh%lower_nodes, repeat(' ', IB * msh%n_lower)), h)
            h = bytes_hash(transfer(msh%lower_group, repeat(' ', IB * msh%n_lower)), h)
        end if
        do i = 1, msh%n_groups
            h = bytes_hash(trim(msh%group_name(i))//achar(0), h)
        end do
    end function checkpoint_mesh_hash

    !> The build's numerics: version, instruction set and compiler.
    pure function checkpoint_build_id() result(id)
        character(len=BUILD_LEN) :: id
        id = DYNCONTACT_VERSION//' '//DYNCONTACT_ISA//' '//compiler_version()
    end function checkpoint_build_id

    !> The header's fields as bytes.
    function header(scene_hash, n_dofs, step, payload) result(h)
        integer(i8), intent(in) :: scene_hash, n_dofs, step   !! scene's hash, free dofs, step saved
        character(len=*), intent(in) :: payload               !! the state's bytes
        character(len=HEADER_BYTES) :: h
        h = MAGIC//transfer(FORMAT_VERSION, 'abcdefgh')//transfer(scene_hash, 'abcdefgh') &
            //transfer(len(payload, i8), 'abcdefgh')//transfer(bytes_hash(payload, 0_i8), 'abcdefgh') &
            //transfer(n_dofs, 'abcdefgh')//transfer(step, 'abcdefgh')//checkpoint_build_id()
    end function header

    !> Write the checkpoint `path` atomically: path.tmp written, fsync'ed, renamed over
    !> path (the previous checkpoint stays until then).
    subroutine checkpoint_write(path, scene_hash, n_dofs, step, buf, stat, errmsg)
        character(len=*), intent(in) :: path                !! checkpoint file
        integer(i8), intent(in) :: scene_hash               !! checkpoint_scene_hash of the run
        integer(i8), intent(in) :: n_dofs                   !! free dofs
        integer(i8), intent(in) :: step                     !! step of the state
        type(byte_buffer_t), intent(in) :: buf              !! payload
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: fd, st2
        character(len=:), allocatable :: tmp
        tmp = trim(path)//'.tmp'
        call fd_open(tmp, fd, stat, errmsg)
        if (stat /= STAT_OK) return
        call fd_write(fd, header(scene_hash, n_dofs, step, buf%data(1:buf%n)), tmp, stat, errmsg)
        if (stat == STAT_OK) call fd_write(fd, buf%data(1:buf%n), tmp, stat, errmsg)
        if (stat == STAT_OK) call fd_sync(fd, tmp, stat, errmsg)
        if (stat == STAT_OK) then
            call fd_close(fd, tmp, stat, errmsg)
        else
            call fd_close(fd, tmp, st2)
        end if
        if (stat == STAT_OK) call file_rename(tmp, path, stat, errmsg)
        if (stat /= STAT_OK) call file_remove(tmp)
    end subroutine checkpoint_write

    !> Read the checkpoint `path` and check it against the run: the payload is returned
    !> only when magic, format, build, scene hash, dofs, size and checksum all match.
    subroutine checkpoint_read(path, scene_hash, n_dofs, payload, step, stat, errmsg)
        character(len=*), intent(in) :: path                !! checkpoint file
        integer(i8), intent(in) :: scene_hash               !! checkpoint_scene_hash of the run
        integer(i8), intent(in) :: n_dofs                   !! free dofs of the run
        character(len=:), allocatable, intent(out) :: payload !! the payload
        integer(i8), intent(out) :: step                    !! step of the state
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=:), allocatable :: bytes
        character(len=HEADER_BYTES) :: h
        integer(i8) :: size, plen
        integer :: unit, ios
        logical :: exists
        stat = STAT_OK
        step = 0
        inquire (file=trim(path), exist=exists, size=size)
        if (.not. exists) then
            call bad('no checkpoint (no such file)')
            return
        end if
        if (size < HEADER_BYTES) then
            call bad('truncated checkpoint ('//int_text(size)//' bytes, the header alone has ' &
                     //int_text(HEADER_BYTES)//')')
            return
        end if
        allocate (character(len=size) :: bytes)
        open (newunit=unit, file=trim(path), access='stream', form='unformatted', &
              action='read', status='old', iostat=ios)
        if (ios == 0) read (unit, iostat=ios) bytes
        if (ios == 0) close (unit)
        if (ios /= 0) then
            call bad('cannot read the checkpoint')
            return
        end if
        h = bytes(1:HEADER_BYTES)
        if (h(1:8) /= MAGIC) then
            call bad('not a dyncontact checkpoint')
        else if (field(2) /= FORMAT_VERSION) then
            call bad('checkpoint format '//int_text(field(2))//', this build reads format ' &
                     //int_text(FORMAT_VERSION))
        else if (h(57:) /= checkpoint_build_id()) then
            call bad('written by another build ('//trim(h(57:))//'; this one is ' &
                     //trim(checkpoint_build_id())//'): its numbers would differ')
        else if (field(3) /= scene_hash) then
            call bad('written by another scene or mesh (the parsed scene or the mesh differs;'// &
                     ' restart with the scene and the mesh that wrote it)')
        else if (field(6) /= n_dofs) then
            call bad('checkpoint of '//int_text(field(6))//' dofs, the run has '//int_text(n_dofs))
        else
            plen = field(4)
            if (plen /= size - HEADER_BYTES) then
                call bad('truncated or extended checkpoint ('//int_text(size)//' bytes, '// &
                         int_text(HEADER_BYTES + max(plen, 0_i8))//' expected)')
            else if (bytes_hash(bytes(HEADER_BYTES + 1:), 0_i8) /= field(5)) then
                call bad('corrupt checkpoint (checksum mismatch)')
            else
                payload = bytes(HEADER_BYTES + 1:)
                step = field(7)
            end if
        end if

    contains

        !> The k-th 8-byte integer of the header.
        pure integer(i8) function field(k)
            integer, intent(in) :: k   !! field number (1-based)
            field = transfer(h(8 * k - 7:8 * k), field)
        end function field

        !> STAT_BAD_INPUT naming the file.
        subroutine bad(why)
            character(len=*), intent(in) :: why   !! what is wrong with the file
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(path)//': '//why//'; refused')
        end subroutine bad
    end subroutine checkpoint_read
end module checkpoint_file
