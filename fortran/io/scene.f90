!> Scene files (SPEC section 3, docs/scenes.md): namelist-format text read by a scan of
!> our own, so that every error is one line naming the file, group and key:
!> "PATH: &group key: what is wrong (got 'VALUE')".
!>
!> Everything about a key is one row of the table in `scene_keys`: group, name, default
!> (namelist text), the check its value must pass and the scene_t component it fills.
!> Defaults, reading, checks and the JSON dump are loops over that table; the few checks
!> that involve several keys are in `validate_cross`, naming their keys.
!>
!> Grammar: text (no control byte other than tab, CR, LF), at most MAX_FILE_BYTES; outside
!> groups only blanks and `!` comments (text with no group is the default scene; a 0-byte
!> file is refused as a failed copy; a leading UTF-8 byte-order mark is skipped); a group is
!> `&name ... /`, known names only, each at most once; inside it, `key = value[, value]`
!> pairs (keys case-insensitive, values separated by commas and/or blanks, line breaks and
!> comments between tokens). Strings are quoted with ' or " (a doubled quote stands for
!> itself, no line break inside); `r*value` repeats a value. The values of a key are
!> converted by one list-directed internal read.
module scene
    use kinds, only: dp, i8
    use text, only: int_text, real_text, utf8_len, lower, json_string
    use errors, only: STAT_OK, STAT_BAD_INPUT, raise
    implicit none
    private

    integer, parameter, public :: PATH_LEN = 1024  !! length of path strings
    integer, parameter, public :: NAME_LEN = 256   !! length of name strings
    integer, parameter :: VALUE_LEN = 200           !! characters of a value quoted in messages

    !> A scene with every default filled in; the defaults are in `scene_keys`.
    type, public :: scene_t
        character(len=PATH_LEN) :: path = ''       !! the scene's name in messages (its file)
        character(len=PATH_LEN) :: mesh_file       !! &mesh file, resolved ('' = built-in bar)
        integer :: mesh_dim                        !! 0: the mesh's (a file's, 2 for the built-in bar)
        real(dp) :: mesh_length                    !! built-in bar length
        real(dp) :: mesh_width                     !! built-in bar width (2D)
        real(dp) :: mesh_h                         !! built-in bar mesh size
        integer :: max_elements                    !! larger meshes are refused
        character(len=NAME_LEN) :: clamped         !! groups with u = 0
        character(len=NAME_LEN) :: slip_x          !! groups with u_x = 0
        character(len=NAME_LEN) :: slip_y          !! groups with u_y = 0
        character(len=NAME_LEN) :: slip_z          !! groups with u_z = 0 (3D)
        character(len=NAME_LEN) :: contact         !! contact boundary groups ('' = none)
        real(dp) :: young                          !! Young's modulus E
        real(dp) :: poisson                        !! Poisson ratio
        real(dp) :: density                        !! rho
        real(dp) :: gravity(3)                     !! body acceleration g (f = rho g)
        character(len=NAME_LEN) :: contact_method  !! 'nitsche' | 'penalty' | 'alm'
        character(len=NAME_LEN) :: multiplier      !! 'integral' | 'nodal' (method 'alm')
        integer :: nitsche_theta                   !! -1, 0 or 1
        real(dp) :: gamma0                         !! gamma_N = gamma0 / h_T
        real(dp) :: obstacle_point(3)              !! a point of the obstacle plane
        real(dp) :: obstacle_normal(3)             !! outward normal into the obstacle, unit length
        real(dp) :: probe(3)                       !! probe point on Gamma_C
        character(len=NAME_LEN) :: quadrature      !! 'exact' or 'gauss'
        integer :: quad_points                     !! Gauss points per facet for 'gauss'
        character(len=NAME_LEN) :: initial_kind    !! 'rest' | 'velocity' | 'compressed_bar'
        real(dp) :: amplitude                      !! compressed_bar lift
        real(dp) :: velocity(3)                    !! 'velocity' initial velocity
        !> Components given for each vector key, in table order (gravity, obstacle_point,
        !> obstacle_normal, probe, velocity); 0 = not given (the default of the dimension).
        integer :: vector_count(5) = 0
        !> The vector keys' values as written (tokens joined by ', '), quoted in the messages
        !> of scene_check_dim; '' = not given.
        character(len=VALUE_LEN) :: vector_written(5) = ''
        !> Whether scene_check_dim has resolved the vector keys against the mesh's dimension.
        !> Before, a vector key not given is dumped as null: its default is the dimension's
        !> (1D, 2D or 3D), known for a mesh file once the file is read.
        logical :: dim_checked = .false.
        !> Whether each key appears in the scene text, in table order (scene_given asks
        !> it by name): the run's warnings about keys that change nothing are about what
        !> the user wrote, whatever its value. Not in scene_to_json (nor, so, in the
        !> checkpoint's scene hash): a key written at its default runs the same numbers.
        logical, allocatable :: given(:)
        character(len=NAME_LEN) :: scheme_name     !! newmark|hht|hht_seed|theta|pc|pc_hht|..._seed
        real(dp) :: alpha                          !! HHT alpha
        real(dp) :: beta                           !! Newmark / pc beta
        real(dp) :: gamma                          !! Newmark / pc gamma
        real(dp) :: time_theta                     !! theta-scheme theta
        real(dp) :: rho_inf                        !! galpha spectral radius at infinity
        real(dp) :: dt                             !! time step
        real(dp) :: t_end                          !! final time
        integer :: max_steps                       !! larger step counts are refused
        character(len=NAME_LEN) :: mass            !! 'consistent' | 'lumped' | 'redistributed'
        real(dp) :: newton_tol                     !! relative residual tolerance
        integer :: newton_maxit                    !! max Newton iterations
        real(dp) :: blowup                         !! unstable above blowup x the energy scale
        character(len=PATH_LEN) :: out_dir         !! output folder
        integer :: every                           !! trace row every this many steps
        integer :: fields_every                    !! VTU snapshot every this many steps (0 = none)
        integer :: checkpoint_every                !! checkpoint every this many steps (0 = none)
        character(len=NAME_LEN) :: solver_kind     !! 'direct' | 'cg' | 'auto'
        real(dp) :: cg_rtol                        !! CG relative residual tolerance
        integer :: cg_max_iter                     !! CG iteration limit of one solve
        integer :: solver_threads                  !! solves' threads: 0 automatic, 1, 2
    end type scene_t

    public :: scene_read, scene_parse, scene_to_json, scene_check_dim, scene_bar_dim
    public :: scene_given, scene_given_names, scene_json_diff

    !> One key: its table row, the component it fills and its value as read.
    type :: key_t
        character(len=8) :: group = ''            !! group name
        character(len=16) :: name = ''            !! key name
        character(len=40) :: default = ''         !! default, as namelist text
        character(len=128) :: check = ''          !! what the value must be ('' = anything)
        character(len=24) :: when = ''            !! schemes the check is for ('' = all,
                                                  !! '!a b' = all but a, b)
        character(len=64) :: hint = ''            !! added to the check's message
        integer, pointer :: i => null()           !! integer component, or
        real(dp), pointer :: r => null()          !! real component, or
        real(dp), pointer :: v(:) => null()       !! vector component (1 to 3 values), or
        character(len=:), pointer :: s => null()  !! string component
        character(len=:), allocatable :: text     !! value as written, tokens joined by ', '
        integer :: nval = 0                       !! number of values (repeats counted)
        logical :: quoted = .false.               !! the first token is a quoted string
        logical :: given = .false.                !! the key appears in the scene
        integer, pointer :: count => null()       !! vector: components given (0 = default)
        character(len=:), pointer :: written => null()  !! vector: its text as written
        character(len=40) :: default1 = ''        !! vector: default in 1D
        character(len=40) :: default3 = ''        !! vector: default in 3D
    end type key_t

    integer, parameter :: MAX_FILE_BYTES = 1048576  !! larger scene files are rejected
    integer, parameter :: EXCERPT_LEN = 40          !! characters of scene text quoted in messages
    character(len=*), parameter :: BLANKS = ' '//achar(9)//achar(10)//achar(13)

contains

    !> The key table: one row per key, in the order of the JSON dump and of the checks.
    !> check: '> x', '>= x', 'in (a, b)' (brackets as in maths, a/b fractions allowed),
    !> 'in m..n', 'not be empty', a list of allowed integers ('1 or 2') or quoted names.
    subroutine scene_keys(scn, keys)
        type(scene_t), target, intent(inout) :: scn          !! the scene the rows point into
        type(key_t), allocatable, intent(out) :: keys(:)     !! the table
        keys = [ &
            row('mesh', 'file', "''", '', s=scn%mesh_file), &
            row('mesh', 'dim', '0', '0, 1, 2 or 3', i=scn%mesh_dim), &
            row('mesh', 'length', '1.0', '> 0', r=scn%mesh_length), &
            row('mesh', 'width', '0.1', '> 0', r=scn%mesh_width), &
            row('mesh', 'h', '0.05', '> 0', r=scn%mesh_h), &
            row('mesh', 'max_elements', '2000000', '> 0', i=scn%max_elements), &
            row('boundary', 'clamped', "'top'", '', s=scn%clamped), &
            row('boundary', 'slip_x', "''", '', s=scn%slip_x), &
            row('boundary', 'slip_y', "''", '', s=scn%slip_y), &
            row('boundary', 'slip_z', "''", '', s=scn%slip_z), &
            row('boundary', 'contact', "'bottom'", '', s=scn%contact), &
            row('material', 'young', '0.6666666666666666', '> 0', r=scn%young), &
            row('material', 'poisson', '0.3333333333333333', 'in (-1, 1/2)', r=scn%poisson), &
            row('material', 'density', '1.0', '> 0', r=scn%density), &
            row('material', 'gravity', '0.0, 0.0', '', v=scn%gravity, n=scn%vector_count(1), &
                w=scn%vector_written(1), default1='0.0', default3='0.0, 0.0, 0.0'), &
            row('contact', 'method', "'nitsche'", "one of 'nitsche', 'penalty', 'alm'", &
                s=scn%contact_method), &
            row('contact', 'multiplier', "'integral'", "'integral' or 'nodal'", s=scn%multiplier), &
            row('contact', 'theta', '1', '-1, 0 or 1', i=scn%nitsche_theta), &
            row('contact', 'gamma0', '10.0', '> 0', r=scn%gamma0), &
            row('contact', 'obstacle_point', '0.0, 0.0', '', v=scn%obstacle_point, &
                n=scn%vector_count(2), w=scn%vector_written(2), default1='0.0', &
                default3='0.0, 0.0, 0.0'), &
            row('contact', 'obstacle_normal', '0.0, -1.0', '', v=scn%obstacle_normal, &
                n=scn%vector_count(3), w=scn%vector_written(3), default1='-1.0', &
                default3='0.0, 0.0, -1.0'), &
            row('contact', 'probe', '0.05, 0.0', '', v=scn%probe, n=scn%vector_count(4), &
                w=scn%vector_written(4), default1='0.0', default3='0.05, 0.05, 0.0'), &
            row('contact', 'quadrature', "'exact'", "'exact' or 'gauss'", s=scn%quadrature), &
            row('contact', 'quad_points', '3', 'in 1..7', i=scn%quad_points), &
            row('initial', 'kind', "'compressed_bar'", &
                "one of 'rest', 'velocity', 'compressed_bar'", s=scn%initial_kind), &
            row('initial', 'amplitude', '0.5', '', r=scn%amplitude), &
            row('initial', 'velocity', '0.0, 0.0', '', v=scn%velocity, n=scn%vector_count(5), &
                w=scn%vector_written(5), default1='0.0', default3='0.0, 0.0, 0.0'), &
            row('scheme', 'name', "'hht'", "one of 'newmark', 'hht', 'hht_seed', 'theta', "// &
                "'galpha', 'pc', 'pc_hht', 'pc_hht_seed', 'central'", s=scn%scheme_name), &
            row('scheme', 'alpha', '0.0', 'in [-1/3, 0]', r=scn%alpha, when='hht pc_hht'), &
            row('scheme', 'beta', '0.25', '> 0', r=scn%beta, when='newmark', &
                hint="(explicit Newmark, beta = 0, is scheme 'central')"), &
            row('scheme', 'gamma', '0.5', '>= 0', r=scn%gamma, when='newmark'), &
            row('scheme', 'theta', '0.5', 'in [1/2, 1]', r=scn%time_theta, when='theta'), &
            row('scheme', 'rho_inf', '1.0', 'in [0, 1]', r=scn%rho_inf, when='galpha'), &
            row('scheme', 'dt', '0.0025', '> 0', r=scn%dt, when='!central', &
                hint="(0, a step chosen by the run, is for scheme 'central')"), &
            row('scheme', 't_end', '15.0', '>= 0', r=scn%t_end), &
            row('scheme', 'max_steps', '100000000', '> 0', i=scn%max_steps), &
            row('scheme', 'mass', "'consistent'", "one of 'consistent', 'lumped', 'redistributed'", &
                s=scn%mass), &
            row('scheme', 'newton_tol', '1e-10', 'in (0, 1)', r=scn%newton_tol), &
            row('scheme', 'newton_maxit', '50', '> 0', i=scn%newton_maxit), &
            row('scheme', 'blowup', '10.0', '> 1', r=scn%blowup), &
            row('output', 'dir', "'out'", 'not be empty', s=scn%out_dir), &
            row('output', 'every', '1', '> 0', i=scn%every), &
            row('output', 'fields_every', '0', '>= 0', i=scn%fields_every), &
            row('output', 'checkpoint_every', '0', '>= 0', i=scn%checkpoint_every), &
            row('solver', 'kind', "'direct'", "one of 'direct', 'cg', 'auto'", s=scn%solver_kind), &
            row('solver', 'cg_rtol', '1e-12', 'in (0, 1)', r=scn%cg_rtol), &
            row('solver', 'cg_max_iter', '500', '> 0', i=scn%cg_max_iter), &
            row('solver', 'threads', '0', '0, 1 or 2', i=scn%solver_threads)]
    end subroutine scene_keys

    !> One row of the key table (exactly one of i, r, v, s is given; n, w, default1 and
    !> default3 with v: the default is the 2D one).
    function row(group, name, default, check, i, r, v, s, when, hint, n, w, default1, &
                 default3) result(k)
        character(len=*), intent(in) :: group, name         !! group and key
        character(len=*), intent(in) :: default             !! default, namelist text
        character(len=*), intent(in) :: check               !! see scene_keys
        integer, target, intent(inout), optional :: i       !! integer component
        real(dp), target, intent(inout), optional :: r      !! real component
        real(dp), target, intent(inout), optional :: v(3)   !! vector component
        integer, target, intent(inout), optional :: n       !! its count of components given
        character(len=*), target, intent(inout), optional :: w  !! its text as written
        character(len=*), intent(in), optional :: default1  !! its default in 1D
        character(len=*), intent(in), optional :: default3  !! its default in 3D
        character(len=*), target, intent(inout), optional :: s  !! string component
        character(len=*), intent(in), optional :: when      !! schemes the check is for
        character(len=*), intent(in), optional :: hint      !! added to the message
        type(key_t) :: k
        k%group = group; k%name = name; k%default = default; k%check = check
        if (present(i)) k%i => i
        if (present(r)) k%r => r
        if (present(v)) k%v => v
        if (present(s)) k%s => s
        if (present(when)) k%when = when
        if (present(hint)) k%hint = hint
        if (present(n)) k%count => n
        if (present(w)) k%written => w
        if (present(default1)) k%default1 = default1
        if (present(default3)) k%default3 = default3
    end function row

    !> Read and validate the scene file `path`. A relative &mesh file is taken from the
    !> scene file's folder. Errors: STAT_BAD_INPUT and one line "PATH: &group key: ...".
    subroutine scene_read(path, scn, stat, errmsg)
        character(len=*), intent(in) :: path                !! scene file
        type(scene_t), intent(out) :: scn                   !! the scene
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=:), allocatable :: text
        integer :: unit, ios, n
        logical :: exists, is_folder

        ios = 1
        n = 0
        text = ''
        if (len_trim(path) > 0) open (newunit=unit, file=trim(path), access='stream', &
            form='unformatted', action='read', status='old', iostat=ios)
        if (ios == 0) then
            inquire (unit=unit, size=n, iostat=ios)
            if (n < 0) ios = 1
            if (ios == 0 .and. n > 0 .and. n <= MAX_FILE_BYTES) then
                deallocate (text)
                allocate (character(len=n) :: text)
                read (unit, iostat=ios) text
            end if
            close (unit)
        end if
        if (ios /= 0) then
            exists = .false.
            is_folder = .false.
            if (len_trim(path) > 0) inquire (file=trim(path), exist=exists)
            ! a run's output folder given for its scene is a likely slip: say what it is
            if (exists) inquire (file=trim(path)//'/.', exist=is_folder)
            if (is_folder) then
                call raise(stat, errmsg, STAT_BAD_INPUT, trim(path)//': a folder, not a scene file')
            else
                call raise(stat, errmsg, STAT_BAD_INPUT, trim(path)//': '// &
                           trim(merge('cannot read scene file', 'no such scene file    ', exists)))
            end if
        else if (n == 0) then    ! a failed copy, not a scene: comments alone give the defaults
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(path)//': empty scene file (0 bytes)')
        else if (n > MAX_FILE_BYTES) then    ! (before the text is looked at: it was not read)
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(path)//': scene file too large '// &
                       '(more than '//int_text(MAX_FILE_BYTES)//' bytes)')
        else if (n >= 2 .and. (text(1:min(2, n)) == char(255)//char(254) .or. &
                               text(1:min(2, n)) == char(254)//char(255))) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(path)//': UTF-16 text (byte-order '// &
                       'mark '//merge('FF FE', 'FE FF', text(1:1) == char(255))// &
                       '); save the scene as UTF-8')
        else
            ! a UTF-8 byte-order mark (some editors write one) is not part of the text
            if (n >= 3) then
                if (text(1:3) == char(239)//char(187)//char(191)) text = text(4:)
            end if
            call scene_parse(text, trim(path), path(1:index(path, '/', back=.true.)), .true., &
                             scn, stat, errmsg)
        end if
    end subroutine scene_read

    !> Parse a scene given as text: the defaults, then the values given, then (if full)
    !> the checks of the table and validate_cross.
    subroutine scene_parse(text, name, base, full, scn, stat, errmsg)
        character(len=*), intent(in) :: text                !! scene text
        character(len=*), intent(in) :: name                !! its name in messages
        character(len=*), intent(in) :: base                !! prefix of a relative mesh file
        logical, intent(in) :: full                         !! .false.: syntax and types only
        type(scene_t), target, intent(out) :: scn           !! the scene
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        type(key_t), allocatable :: keys(:)
        character(len=:), allocatable :: msg
        integer :: k, pos, dim

        scn%path = name
        call scene_keys(scn, keys)
        msg = ''
        do k = 1, size(keys)   ! the defaults are read as values in a scene are
            pos = 1
            call read_values(trim(keys(k)%default), pos, keys(k), 'default', msg)
            call convert(keys(k), 'default of '//trim(keys(k)%name), msg)
        end do
        if (len(msg) == 0) call tokenize(text, name, keys, msg)
        do k = 1, size(keys)
            ! the dimension as far as it is known (&mesh comes first in the table): the
            ! built-in bar's, or a mesh file's dim if given (0: known once the file is read)
            dim = merge(scene_bar_dim(scn%mesh_dim), scn%mesh_dim, len_trim(scn%mesh_file) == 0)
            if (scn%mesh_dim < 0 .or. scn%mesh_dim > 3) dim = 0
            if (keys(k)%given) call convert(keys(k), key_ctx(name, keys(k)), msg, dim)
            if (associated(keys(k)%count)) then
                keys(k)%count = merge(keys(k)%nval, 0, keys(k)%given)
                if (keys(k)%given) keys(k)%written = shown(keys(k)%text, VALUE_LEN - 3)
            end if
        end do
        ! the built-in bar's dimension is known now (a mesh file's once it is read): the
        ! vector keys' counts and defaults. Not in a syntax-only parse (Scene.set), so that a
        ! scene can change &mesh dim and its vectors one after the other.
        if (full .and. len(msg) == 0 .and. len_trim(scn%mesh_file) == 0 .and. &
            scn%mesh_dim >= 0 .and. scn%mesh_dim <= 3) &
            call vector_dims(keys, name, scene_bar_dim(scn%mesh_dim), msg)
        scn%given = keys%given
        if (full .and. len(msg) == 0) call validate(keys, name, msg)
        if (full .and. len(msg) == 0) call validate_cross(keys, scn, name, base, msg)
        stat = STAT_OK
        if (len(msg) > 0) call raise(stat, errmsg, STAT_BAD_INPUT, msg)
    end subroutine scene_parse

    !> Whether the scene text gives &group key (whatever its value); .false. for a key not
    !> in the table.
    logical function scene_given(scn, group, name)
        type(scene_t), intent(in) :: scn       !! the scene as read
        character(len=*), intent(in) :: group  !! group name
        character(len=*), intent(in) :: name   !! key name
        type(scene_t), target :: copy
        type(key_t), allocatable :: keys(:)
        integer :: k
        scene_given = .false.
        if (.not. allocated(scn%given)) return
        copy = scn
        call scene_keys(copy, keys)
        k = key_index(keys, group, name)
        if (k > 0 .and. name /= '') scene_given = scn%given(k)
    end function scene_given

    !> The keys the scene text gives, as 'group.key' separated by blanks, in table order
    !> ('' if none).
    function scene_given_names(scn) result(s)
        type(scene_t), intent(in) :: scn    !! the scene as read
        character(len=:), allocatable :: s
        type(scene_t), target :: copy
        type(key_t), allocatable :: keys(:)
        integer :: k
        s = ''
        if (.not. allocated(scn%given)) return
        copy = scn
        call scene_keys(copy, keys)
        do k = 1, size(keys)
            if (scn%given(k)) s = s//' '//trim(keys(k)%group)//'.'//trim(keys(k)%name)
        end do
        if (len(s) > 0) s = s(2:)
    end function scene_given_names

    !> The scene as JSON: {"group": {"key": value, ...}, ...} in table order. Vectors have
    !> 2 components (1D: the second is 0), 3 in 3D; before scene_check_dim a vector key not
    !> given is null (its default depends on the mesh's dimension).
    function scene_to_json(scn) result(json)
        type(scene_t), intent(in) :: scn    !! the scene
        character(len=:), allocatable :: json
        type(scene_t), target :: copy
        type(key_t), allocatable :: keys(:)
        integer :: k

        copy = scn
        call scene_keys(copy, keys)
        json = '{"'//trim(keys(1)%group)//'": {'
        do k = 1, size(keys)
            if (k > 1 .and. keys(k)%group /= keys(max(k - 1, 1))%group) then
                json = json//'}, "'//trim(keys(k)%group)//'": {'
            else if (k > 1) then
                json = json//', '
            end if
            json = json//'"'//trim(keys(k)%name)//'": '
            if (associated(keys(k)%i)) json = json//int_text(keys(k)%i)
            if (associated(keys(k)%r)) json = json//real_text(keys(k)%r)
            ! (count is read only for a vector key: Fortran's .and. need not short-circuit,
            ! and the other keys' count is a null pointer)
            if (associated(keys(k)%v)) then
                if (keys(k)%count == 0 .and. .not. scn%dim_checked) then
                    json = json//'null'    ! not given: the default of the mesh's dimension
                else
                    json = json//'['//real_text(keys(k)%v(1))//', '//real_text(keys(k)%v(2))
                    if (keys(k)%count == 3) json = json//', '//real_text(keys(k)%v(3))
                    json = json//']'
                end if
            end if
            if (associated(keys(k)%s)) json = json//json_string(trim(keys(k)%s))
        end do
        json = json//'}}'
    end function scene_to_json

    !> The keys whose values differ between two scenes' JSON as scene_to_json writes them
    !> ('&material young: 1.0E+000 here, 6.666666666666666E-001 there'; several joined by
    !> '; '), leaving out the keys of `skip` (' group.key group.key ... '); a key of one
    !> text that the other lacks counts as different. '' when none differ, or when either
    !> text is not such JSON (the caller then says nothing more).
    pure function scene_json_diff(here, there, skip) result(diff)
        character(len=*), intent(in) :: here    !! the run's scene JSON
        character(len=*), intent(in) :: there   !! the other scene's JSON (summary.json's)
        character(len=*), intent(in) :: skip    !! keys not compared, blank-separated
        character(len=:), allocatable :: diff
        integer, parameter :: MAX_KEYS = 200
        character(len=80) :: names_a(MAX_KEYS), names_b(MAX_KEYS)
        integer :: va(2, MAX_KEYS), vb(2, MAX_KEYS), na, nb, i, j
        logical :: ok_a, ok_b
        diff = ''
        call json_pairs(here, names_a, va, na, ok_a)
        call json_pairs(there, names_b, vb, nb, ok_b)
        if (.not. (ok_a .and. ok_b) .or. na == 0 .or. nb == 0) return
        do i = 1, na
            if (index(skip, ' '//trim(names_a(i))//' ') > 0) cycle
            do j = 1, nb
                if (names_b(j) == names_a(i)) exit
            end do
            if (j <= nb) then
                if (here(va(1, i):va(2, i)) == there(vb(1, j):vb(2, j))) cycle
            end if
            if (len(diff) > 0) diff = diff//'; '
            diff = diff//'&'//replace_dot(trim(names_a(i)))//': '//here(va(1, i):va(2, i))// &
                   ' here, '
            if (j <= nb) then
                diff = diff//there(vb(1, j):vb(2, j))//' there'
            else
                diff = diff//'not there'
            end if
        end do
    contains
        !> 'group.key' as '&group key'
        pure function replace_dot(name) result(r)
            character(len=*), intent(in) :: name  !! group.key
            character(len=:), allocatable :: r
            integer :: k
            k = index(name, '.')
            r = name(1:k - 1)//' '//name(k + 1:)
        end function replace_dot
    end function scene_json_diff

    !> The 'group.key' names of a scene's JSON, {"group": {"key": value, ...}, ...}, and
    !> where each value's text lies (first and last character); ok = .false. when the text
    !> does not have that form (or more keys than fit).
    pure subroutine json_pairs(text, names, where, n, ok)
        character(len=*), intent(in) :: text          !! the JSON
        character(len=*), intent(out) :: names(:)     !! group.key of each value
        integer, intent(out) :: where(:, :)           !! (2, n): first and last character
        integer, intent(out) :: n                     !! values found
        logical, intent(out) :: ok                    !! the text had the form
        character(len=80) :: group
        integer :: i, depth, start, q
        n = 0
        ok = .false.
        group = ''
        depth = 0
        i = 1
        do while (i <= len(text))
            select case (text(i:i))
            case ('{')
                depth = depth + 1
            case ('}')
                depth = depth - 1
                if (depth == 0) exit
            case ('"')
                q = json_string_end(text, i)
                if (q == 0) return
                if (depth == 1) then
                    group = text(i + 1:q - 1)
                else if (depth == 2) then
                    if (n >= size(names)) return
                    n = n + 1
                    names(n) = trim(group)//'.'//text(i + 1:q - 1)
                    start = q + 1
                    do while (start <= len(text))     ! past ': '
                        if (text(start:start) /= ':' .and. text(start:start) /= ' ') exit
                        start = start + 1
                    end do
                    i = json_value_end(text, start)
                    if (i == 0) return
                    where(:, n) = [start, i]
                else
                    return
                end if
                i = q
                if (depth == 2) i = where(2, n)
            end select
            i = i + 1
        end do
        ok = depth == 0
    end subroutine json_pairs

    !> Position of the quote that ends the JSON string starting at text(i:i) ('"'), 0 if
    !> none (a backslash escapes the next character).
    pure function json_string_end(text, i) result(q)
        character(len=*), intent(in) :: text  !! the JSON
        integer, intent(in) :: i              !! its opening quote
        integer :: q
        q = i + 1
        do while (q <= len(text))
            if (text(q:q) == '\') then
                q = q + 2
                cycle
            end if
            if (text(q:q) == '"') return
            q = q + 1
        end do
        q = 0
    end function json_string_end

    !> Last character of the JSON value starting at text(start:start) (a number, null, a
    !> string or an array of numbers), 0 if it does not end.
    pure function json_value_end(text, start) result(last)
        character(len=*), intent(in) :: text  !! the JSON
        integer, intent(in) :: start          !! the value's first character
        integer :: last
        last = 0
        if (start > len(text)) return
        if (text(start:start) == '"') then
            last = json_string_end(text, start)
        else if (text(start:start) == '[') then
            last = index(text(start:), ']')
            if (last > 0) last = start + last - 1
        else
            last = start
            do while (last < len(text))
                if (scan(text(last + 1:last + 1), ',}') > 0) exit
                last = last + 1
            end do
            last = len_trim(text(1:last))
        end if
    end function json_value_end

    ! ---------------------------------------------------------------- scanning

    !> Split `text` into groups and `key = values`, marking the keys given.
    pure subroutine tokenize(text, name, keys, msg)
        character(len=*), intent(in) :: text                 !! scene text
        character(len=*), intent(in) :: name                 !! scene name (messages)
        type(key_t), intent(inout) :: keys(:)                !! the table
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        character(len=:), allocatable :: ctx, group, key
        integer :: i, j, k, seen(size(keys))

        do i = 1, len(text)
            k = iachar(text(i:i))
            if ((k < 32 .and. k /= 9 .and. k /= 10 .and. k /= 13) .or. k == 127) then
                msg = name//': not a text file (control character on line '// &
                      int_text(line_of(text, i))//')'
                return
            end if
        end do
        seen = 0
        group = ''
        i = 1
        do
            call skip_blanks(text, i)
            if (i > len(text)) return
            ctx = name//': line '//int_text(line_of(text, i))
            j = ident_end(text, i + 1)
            if (text(i:i) /= '&') then
                msg = ctx//': text outside a group'//got(text, i); return
            else if (j == i + 1) then
                msg = ctx//': ''&'' without a group name'//got(text, i); return
            end if
            group = shown(lower(text(i + 1:j - 1)))
            ctx = name//': &'//group
            k = key_index(keys, group, '')
            if (k == 0) then
                msg = ctx//': unknown group (expected one of '//names(keys, '')//')'; return
            else if (seen(k) > 0) then
                msg = ctx//': group given twice (lines '//int_text(seen(k))//' and '// &
                      int_text(line_of(text, i))//')'; return
            else if (verify(text(j:min(j, len(text))), BLANKS//'/!') /= 0) then
                msg = ctx//': expected a blank after the group name'//got(text, j); return
            end if
            seen(k) = line_of(text, i)
            i = j
            do    ! the group's keys
                call skip_blanks(text, i)
                if (i > len(text)) exit
                if (text(i:i) == '/' .or. text(i:i) == '&') exit
                j = ident_end(text, i)
                if (j == i) then
                    msg = ctx//': expected a key name'//got(text, i); return
                end if
                key = shown(lower(text(i:j - 1)))
                k = key_index(keys, group, key)
                if (k == 0) then
                    msg = ctx//' '//key//': unknown key (expected one of '// &
                          names(keys, group)//')'; return
                else if (keys(k)%given) then
                    msg = ctx//' '//key//': key given twice'; return
                end if
                i = j
                call skip_blanks(text, i)
                if (i > len(text)) exit
                if (text(i:i) /= '=') then
                    msg = ctx//' '//key//': expected ''='' after the key'//got(text, i); return
                end if
                i = i + 1
                keys(k)%given = .true.
                call read_values(text, i, keys(k), ctx//' '//key, msg)
                if (len(msg) > 0) return
            end do
            if (i > len(text)) then
                msg = ctx//': unterminated group (no ''/'' before the end of the file)'; return
            else if (text(i:i) == '&') then
                msg = ctx//': unterminated group (no ''/'' before the next group)'// &
                      got(text, i); return
            end if
            i = i + 1
        end do
    end subroutine tokenize

    !> The values of one key, from just after its '=' up to the next key, '/' or '&':
    !> sets key%text (tokens joined by ', '), key%nval and key%quoted.
    pure subroutine read_values(text, i, key, ctx, msg)
        character(len=*), intent(in) :: text                 !! scene text
        integer, intent(inout) :: i                          !! position
        type(key_t), intent(inout) :: key                    !! the key
        character(len=*), intent(in) :: ctx                  !! 'NAME: &group key'
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        logical :: expect
        integer :: j, p, rep

        key%text = ''
        key%nval = 0
        key%quoted = .false.
        expect = .true.
        do
            call skip_blanks(text, i)
            if (i > len(text)) exit
            if (text(i:i) == '/' .or. text(i:i) == '&') exit
            if (text(i:i) == ',' .and. expect) then
                msg = ctx//': empty value'//got(text, i); return
            else if (text(i:i) == ',') then
                expect = .true.
                i = i + 1
                cycle
            else if (text(i:i) == '=') then
                msg = ctx//': unexpected ''='''//got(text, i); return
            end if
            rep = 1
            if (text(i:i) == '''' .or. text(i:i) == '"') then
                j = string_end(text, i)
                if (j == 0) then
                    msg = ctx//': unterminated string'//got(text, i); return
                else if (verify(text(j:min(j, len(text))), BLANKS//',/!') /= 0) then
                    msg = ctx//': unexpected text after a string'//got(text, i); return
                end if
                key%quoted = key%quoted .or. key%nval == 0
            else
                j = scan(text(i:), BLANKS//',/!=')
                j = merge(len(text) + 1, i + j - 1, j == 0)
                p = j    ! an identifier followed by '=' is the next key
                call skip_blanks(text, p)
                if (ident_end(text, i) == j .and. p <= len(text)) then
                    if (text(p:p) == '=') exit
                end if
                p = index(text(i:j - 1), '*')    ! r*value
                if (p > 1 .and. verify(text(i:i + p - 2), '0123456789') == 0) then
                    rep = 1000    ! more than any key takes
                    if (p <= 4) read (text(i:i + p - 2), *) rep
                    if (i + p > j - 1) then
                        msg = ctx//': empty value'//got(text, i); return
                    else if (rep == 0) then
                        msg = ctx//': repeat count must be > 0'//got(text, i); return
                    end if
                end if
            end if
            if (len(key%text) <= VALUE_LEN) then    ! what a message quotes, then '...'
                if (key%nval > 0) key%text = key%text//', '
                key%text = key%text//text(i:j - 1)
            end if
            key%nval = min(key%nval + rep, 1000)
            expect = .false.
            i = j
        end do
        if (key%nval == 0) msg = ctx//': missing value'//got(text, i)
    end subroutine read_values

    !> Convert key%text into the key's component: count, type, range of the type.
    pure subroutine convert(key, ctx, msg, dim)
        type(key_t), intent(inout) :: key                    !! the key
        character(len=*), intent(in) :: ctx                  !! 'NAME: &group key'
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        integer, intent(in), optional :: dim                 !! mesh dimension, 0 = not known
        character(len=len(key%text)) :: buf
        character(len=:), allocatable :: what
        integer(i8) :: big
        real(dp) :: x(3)
        integer :: ios

        if (len(msg) > 0) return
        what = ''
        x = 0.0_dp
        ios = 1
        if (associated(key%v) .and. key%nval > 3) then
            what = 'expected 1, 2 or 3 values'
            if (present(dim)) then
                if (dim == 3) what = 'expected 3 values in 3D'
                if (dim == 1 .or. dim == 2) what = 'expected 1 or 2 values in '//int_text(dim)//'D'
            end if
        else if (.not. associated(key%v) .and. key%nval /= 1) then
            what = 'expected 1 value'
        else if (associated(key%i)) then
            ! more than 18 characters (leading zeros included) is out of range
            if (len(key%text) <= 18) read (key%text, *, iostat=ios) big
            if (key%quoted) then
                what = 'expected an integer, not a string'
            else if (verify(key%text(1:1), '+-0123456789') /= 0 .or. &
                     verify(key%text(2:), '0123456789') /= 0 .or. &
                     scan(key%text, '0123456789') == 0) then
                what = 'expected an integer'
            else if (ios /= 0 .or. abs(big) > huge(key%i)) then
                what = 'integer out of range'
            else
                key%i = int(big)
            end if
        else if (associated(key%s)) then
            read (key%text, *, iostat=ios) buf
            if (.not. key%quoted .or. ios /= 0) then
                what = 'expected a quoted string'
            else if (len_trim(buf) > len(key%s)) then
                msg = ctx//': string too long (more than '//int_text(len(key%s))//' characters)'
            else if (utf8_bad(trim(buf)) > 0) then    ! it ends up in summary.json
                ios = iachar(buf(utf8_bad(trim(buf)):utf8_bad(trim(buf))))
                msg = ctx//': not UTF-8 text (byte '//int_text(ios)//' at character '// &
                      int_text(utf8_bad(trim(buf)))//'; save the scene as UTF-8)'
            else
                key%s = buf
            end if
        else
            read (key%text, *, iostat=ios) x(1:key%nval)
            if (key%quoted) then
                what = 'expected a real number, not a string'
            else if (ios /= 0 .or. .not. real_syntax(key%text)) then    ! no nan, inf, 1-3
                what = 'expected a real number'
            else if (.not. all(abs(x) <= huge(x))) then
                what = 'real number out of range'
            else if (associated(key%r)) then
                key%r = x(1)
            else
                key%v = x
            end if
        end if
        if (len(what) > 0 .and. key%quoted) then     ! 'abc' as written, not ''abc''
            msg = ctx//': '//what//' (got "'//shown(key%text, VALUE_LEN)//'")'
        else if (len(what) > 0) then
            msg = ctx//': '//what//' (got '''//shown(key%text, VALUE_LEN)//''')'
        end if
    end subroutine convert

    !> Whether every value in `text` (values joined by ', ', each maybe `r*`-prefixed) is a
    !> real written [sign] digits [. digits] [e|d [sign] digits]. The list-directed read
    !> also takes forms that hide a typing slip, refused here: nan and inf, an exponent
    !> without its letter (`2.5+1` reads as 25), text after a ';' (`1e-3;5` reads as 1e-3).
    pure logical function real_syntax(text) result(ok)
        character(len=*), intent(in) :: text   !! key%text
        integer :: i, j, n, digits
        ok = .false.
        n = len(text)
        i = 1
        do while (i <= n)
            j = index(text(i:), '*')    ! repeat count (checked by read_values)
            if (j > 1 .and. j <= scan(text(i:)//',', ',')) then
                if (verify(text(i:i + j - 2), '0123456789') == 0) i = i + j
            end if
            call skip_sign(i)
            call skip_digits(i, digits)
            if (i <= n) then
                if (text(i:i) == '.') then
                    i = i + 1
                    call skip_digits(i, j)
                    digits = digits + j
                end if
            end if
            if (digits == 0) return
            if (i <= n) then
                if (scan(text(i:i), 'eEdD') == 1) then
                    i = i + 1
                    call skip_sign(i)
                    call skip_digits(i, digits)
                    if (digits == 0) return
                end if
            end if
            if (i > n) exit
            if (text(i:min(i + 1, n)) /= ', ') return
            i = i + 2
        end do
        ok = .true.
    contains
        !> Moves i past a '+' or '-' at text(i).
        pure subroutine skip_sign(i)
            integer, intent(inout) :: i   !! position in text
            if (i <= n) then
                if (scan(text(i:i), '+-') == 1) i = i + 1
            end if
        end subroutine skip_sign

        !> Moves i past the digits from text(i); count: how many there were.
        pure subroutine skip_digits(i, count)
            integer, intent(inout) :: i    !! position in text
            integer, intent(out) :: count  !! digits skipped
            count = 0
            do while (i <= n)
                if (scan(text(i:i), '0123456789') /= 1) exit
                i = i + 1
                count = count + 1
            end do
        end subroutine skip_digits
    end function real_syntax

    !> Position of the first byte of s that is not part of well-formed UTF-8 (utf8_len),
    !> 0 if s is UTF-8. A string value is written into summary.json, which is UTF-8.
    pure integer function utf8_bad(s) result(bad)
        character(len=*), intent(in) :: s   !! text
        integer :: i, n
        i = 1
        bad = 0
        do while (i <= len(s))
            n = utf8_len(s, i)
            if (n == 0) then
                bad = i; return
            end if
            i = i + n
        end do
    end function utf8_bad

    ! ---------------------------------------------------------------- checks

    !> The checks of the key table, in table order.
    pure subroutine validate(keys, name, msg)
        type(key_t), intent(in) :: keys(:)                   !! the table, values read
        character(len=*), intent(in) :: name                 !! scene name (messages)
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        character(len=:), allocatable :: c, scheme, what
        real(dp) :: x
        integer :: k, p
        logical :: ok

        scheme = trim(keys(key_index(keys, 'scheme', 'name'))%s)
        do k = 1, size(keys)
            c = trim(keys(k)%check)
            if (len(c) == 0) cycle
            if (keys(k)%when(1:1) == '!') then      ! every scheme but those listed
                if (index(' '//trim(keys(k)%when(2:))//' ', ' '//scheme//' ') > 0) cycle
            else if (len_trim(keys(k)%when) > 0 .and. &
                     index(' '//trim(keys(k)%when)//' ', ' '//scheme//' ') == 0) then
                cycle
            end if
            x = 0.0_dp
            if (associated(keys(k)%i)) x = real(keys(k)%i, dp)
            if (associated(keys(k)%r)) x = keys(k)%r
            p = max(index(c, ','), index(c, '..'))
            if (c(1:1) == '>') then
                p = merge(3, 2, c(2:2) == '=')
                ok = x > number(c(p:)) .or. (p == 3 .and. x >= number(c(p:)))
            else if (c(1:min(len(c), 4)) == 'in [' .or. c(1:min(len(c), 4)) == 'in (') then
                ok = (x > number(c(5:p - 1)) .or. (c(4:4) == '[' .and. x >= number(c(5:p - 1)))) &
                     .and. (x < number(c(p + 1:len(c) - 1)) .or. &
                            (c(len(c):) == ']' .and. x <= number(c(p + 1:len(c) - 1))))
            else if (c(1:min(len(c), 3)) == 'in ') then
                ok = x >= number(c(4:p - 1)) .and. x <= number(c(p + 2:))
            else if (c == 'not be empty') then
                ok = len_trim(keys(k)%s) > 0
            else if (associated(keys(k)%s)) then
                ok = index(c, ''''//trim(keys(k)%s)//'''') > 0 .and. scan(keys(k)%s, '''') == 0
            else    ! '1 or 2', '-1, 0 or 1'
                ok = index(' '//c//' ', ' '//int_text(keys(k)%i)//' ') > 0 .or. &
                     index(' '//c, ' '//int_text(keys(k)%i)//',') > 0
            end if
            if (ok) cycle
            what = 'must '//merge('    ', 'be  ', c(1:3) == 'not')
            what = trim(what)//' '//c
            if (len_trim(keys(k)%when) > 0 .and. keys(k)%when(1:1) /= '!') &
                what = what//' for scheme '''//scheme//''''
            if (len_trim(keys(k)%hint) > 0) what = what//' '//trim(keys(k)%hint)
            msg = bad(keys, name, keys(k)%group, keys(k)%name, what)
            return
        end do
    end subroutine validate

    !> The checks that involve several keys or the file system; resolves the mesh file and
    !> normalizes the obstacle normal.
    subroutine validate_cross(keys, scn, name, base, msg)
        type(key_t), intent(in) :: keys(:)                   !! the table, values read
        type(scene_t), intent(inout) :: scn                  !! the scene the table fills
        character(len=*), intent(in) :: name                 !! scene name (messages)
        character(len=*), intent(in) :: base                 !! prefix of a relative mesh file
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        character(len=:), allocatable :: file
        character(len=1) :: c1
        real(dp) :: nrm, n_elem
        integer :: unit, ios, nbytes

        file = trim(scn%mesh_file)
        if (len(file) > 0) then
            if (file(1:1) /= '/') file = base//file
            ios = 1
            if (len(file) <= PATH_LEN) open (newunit=unit, file=file, access='stream', &
                form='unformatted', action='read', status='old', iostat=ios)
            if (ios == 0) then
                inquire (unit=unit, size=nbytes)
                if (nbytes > 0) read (unit, iostat=ios) c1
                close (unit)
            end if
            if (len(file) > PATH_LEN) then
                msg = bad(keys, name, 'mesh', 'file', 'resolved path too long'); return
            else if (ios /= 0) then
                ! a relative path here was given relative to the current folder (a scene
                ! text or a Python Scene.set / --set value, which has no folder of its own)
                if (file(1:1) /= '/' .and. len(base) > 0 .and. scn%mesh_file(1:1) /= '/') then
                    ! the scene file's folder was put before it: the path says where it looked
                    msg = bad(keys, name, 'mesh', 'file', 'cannot read mesh file '''// &
                              shown(file, VALUE_LEN)//''' (a relative path counts from the'// &
                              ' scene file''s folder)')
                else if (file(1:1) /= '/') then
                    msg = bad(keys, name, 'mesh', 'file', 'cannot read mesh file '''// &
                              shown(file, VALUE_LEN)//''' in the current folder')
                else
                    msg = bad(keys, name, 'mesh', 'file', 'cannot read mesh file '''// &
                              shown(file, VALUE_LEN)//'''')
                end if
                return
            end if
            scn%mesh_file = file
        else
            ! the built-in bar: 1D n segments, 2D 2 nx ny triangles (bar_mesh.f90)
            n_elem = max(1.0_dp, anint(scn%mesh_length / scn%mesh_h))
            if (scene_bar_dim(scn%mesh_dim) == 2) &
                n_elem = 2 * n_elem * max(1.0_dp, anint(scn%mesh_width / scn%mesh_h))
            if (scn%mesh_dim == 3) &
                n_elem = 6 * n_elem * max(1.0_dp, anint(scn%mesh_width / scn%mesh_h))**2
            if (n_elem > scn%max_elements) then
                msg = bad(keys, name, 'mesh', 'h', 'the built-in bar would have '// &
                          real_text(n_elem, 4)//' elements, more than &mesh max_elements = ' &
                          //int_text(scn%max_elements)); return
            end if
        end if
        nrm = norm2(scn%obstacle_normal)
        if (scn%mesh_dim == 1 .and. len(file) == 0) then    ! dim counts for the bar only
            if (scn%obstacle_normal(1) == 0.0_dp) then
                msg = bad(keys, name, 'contact', 'obstacle_normal', &
                          'component 1 must be nonzero in 1D'); return
            end if
            scn%obstacle_normal = [sign(1.0_dp, scn%obstacle_normal(1)), 0.0_dp, 0.0_dp]
        else if (.not. (nrm > 0.0_dp .and. nrm <= huge(nrm))) then
            msg = bad(keys, name, 'contact', 'obstacle_normal', 'must be a nonzero vector'); return
        else if (abs(nrm - 1.0_dp) > 4.0_dp * epsilon(nrm)) then
            ! a unit normal (to round-off) is kept as is: normalizing twice changes nothing
            scn%obstacle_normal = scn%obstacle_normal / nrm
        end if
        select case (trim(scn%scheme_name))
        case ('pc', 'pc_hht', 'pc_hht_seed', 'central')
            if (scn%contact_method == 'alm') then
                msg = bad(keys, name, 'contact', 'method', 'the augmented Lagrangian (multipliers'// &
                          ' solved with the displacement by Newton) needs an implicit scheme, and '// &
                          explicit_text(scn%scheme_name)); return
            end if
            if (scn%mass == 'redistributed') then
                msg = bad(keys, name, 'scheme', 'mass', 'the redistributed mass (no inertia on'// &
                          ' the contact nodes) needs an implicit scheme, and '// &
                          explicit_text(scn%scheme_name)); return
            end if
        end select
        ! CG leaves a residual of at most cg_rtol |R(u^n)| that Newton's test does not see
        ! (it tests the contact part after the first solve): keep it under the test's own
        ! tolerance (|R(u^n)| <= the test's scale)
        if (scn%solver_kind /= 'direct' .and. scn%cg_rtol > scn%newton_tol) then
            msg = bad(keys, name, 'solver', 'cg_rtol', 'must be at most &scheme newton_tol = '// &
                      real_text(scn%newton_tol, 4)); return
        end if
        if (scn%dt < 0.0_dp) then      ! central (the row checks the others)
            msg = bad(keys, name, 'scheme', 'dt', 'must be >= 0 for scheme ''central'' '// &
                      '(0: a step chosen by the run)'); return
        end if
        if (scn%dt == 0.0_dp) return   ! the step count is known once central has chosen dt
        ! the run makes ceiling(t_end/dt - 1e-9) steps (simulation.f90)
        if (scn%t_end > 0.0_dp .and. scn%t_end / scn%dt < 1.0_dp - 1.0e-9_dp) then
            msg = bad(keys, name, 'scheme', 't_end', 'must be 0 or at least dt = '// &
                      real_text(scn%dt, 4))
        else if (scn%t_end / scn%dt - 1.0e-9_dp > scn%max_steps) then
            msg = bad(keys, name, 'scheme', 'dt', 't_end / dt = '// &
                      real_text(scn%t_end / scn%dt, 4)//' steps, more than &scheme max_steps = ' &
                      //int_text(scn%max_steps))
        end if
    end subroutine validate_cross

    !> The built-in bar's dimension for &mesh dim = d (0, the default: 2).
    pure integer function scene_bar_dim(d)
        integer, intent(in) :: d   !! &mesh dim
        scene_bar_dim = merge(2, d, d == 0)
    end function scene_bar_dim

    !> The keys that depend on the mesh dimension: the vector keys take 3 components in 3D,
    !> 1 or 2 in 1D and 2D (a key not given takes the dimension's default); &contact quad_points
    !> (with 'gauss') is 1..6 in 2D, 1, 3, 6 or 7 in 3D. For a mesh read from a file, once its
    !> dimension is known; with a mesh file, &mesh dim must be 0 or the file's dimension.
    !> Errors: STAT_BAD_INPUT, "PATH: &group key: ..." naming the dimension.
    subroutine scene_check_dim(scn, dim, stat, errmsg)
        type(scene_t), intent(inout) :: scn                 !! the scene (3D defaults filled in)
        integer, intent(in) :: dim                          !! mesh dimension
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        type(scene_t), target :: copy
        type(key_t), allocatable :: keys(:)
        character(len=:), allocatable :: msg
        integer :: k
        copy = scn
        call scene_keys(copy, keys)
        do k = 1, size(keys)      ! the table's texts of the values as in the scene
            if (.not. associated(keys(k)%v)) cycle
            keys(k)%given = keys(k)%count > 0
            keys(k)%nval = keys(k)%count
            keys(k)%text = trim(keys(k)%written)
        end do
        msg = ''
        if (len_trim(scn%mesh_file) > 0 .and. scn%mesh_dim /= 0 .and. scn%mesh_dim /= dim) then
            msg = trim(scn%path)//': &mesh dim: '//int_text(scn%mesh_dim)//' given, but the '// &
                  "mesh file '"//shown(trim(scn%mesh_file), VALUE_LEN)//"' is "//int_text(dim)// &
                  'D (dim is for the built-in bar: leave it out with a mesh file, or give '// &
                  int_text(dim)//')'
        else
            call vector_dims(keys, trim(scn%path), dim, msg)
        end if
        stat = STAT_OK
        if (len(msg) > 0) then
            call raise(stat, errmsg, STAT_BAD_INPUT, msg)
        else
            ! from here on the dump shows the defaults: 3 components in 3D
            where (copy%vector_count == 0 .and. dim == 3) copy%vector_count = 3
            copy%dim_checked = .true.
            scn = copy
        end if
    end subroutine scene_check_dim

    !> See scene_check_dim (on the key table, values read).
    pure subroutine vector_dims(keys, name, dim, msg)
        type(key_t), intent(inout) :: keys(:)                !! the table, values read
        character(len=*), intent(in) :: name                 !! scene name (messages)
        integer, intent(in) :: dim                           !! mesh dimension
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        integer :: k, pos, nq
        logical :: gauss
        k = key_index(keys, 'contact', 'quad_points')
        nq = keys(k)%i
        gauss = keys(key_index(keys, 'contact', 'quadrature'))%s == 'gauss'
        if (gauss .and. dim == 2 .and. nq == 7) then
            msg = key_ctx(name, keys(k))//': must be in 1..6 in 2D (Gauss-Legendre points a '// &
                  'segment facet; got '''//int_text(nq)//''')'
            return
        else if (gauss .and. dim == 3 .and. .not. any(nq == [1, 3, 6, 7])) then
            msg = key_ctx(name, keys(k))//': must be 1, 3, 6 or 7 in 3D (symmetric rules on '// &
                  'a triangle facet; got '''//int_text(nq)//''')'
            return
        else if (gauss .and. dim >= 2 .and. nq == 1 .and. &
                 keys(key_index(keys, 'contact', 'method'))%s == 'alm' .and. &
                 keys(key_index(keys, 'contact', 'multiplier'))%s == 'integral') then
            ! one point a facet gives the multipliers' mass matrix rank 1 a facet, fewer
            ! than its dim multipliers: the multiplier system is singular
            msg = key_ctx(name, keys(k))//': must be at least '//int_text(dim)// &
                  ' with &contact method = ''alm'' and multiplier = ''integral'' in '// &
                  int_text(dim)//'D (one point a facet leaves the multiplier system singular)'
            return
        end if
        do k = 1, size(keys)
            if (.not. associated(keys(k)%count)) cycle
            if ((dim == 1 .or. dim == 3) .and. .not. keys(k)%given) then
                pos = 1
                keys(k)%text = ''
                keys(k)%nval = 0
                call read_values(trim(merge(keys(k)%default1, keys(k)%default3, dim == 1)), &
                                 pos, keys(k), 'default', msg)
                call convert(keys(k), 'default of '//trim(keys(k)%name), msg)
            else if (dim == 3 .and. keys(k)%nval /= 3) then
                msg = key_ctx(name, keys(k))//': expected 3 values in 3D (got '''// &
                      shown(keys(k)%text, VALUE_LEN)//''')'
                return
            else if (dim < 3 .and. keys(k)%nval > 2) then
                msg = key_ctx(name, keys(k))//': expected 1 or 2 values in '//int_text(dim)// &
                      'D (got '''//shown(keys(k)%text, VALUE_LEN)//''')'
                return
            else if (dim == 1 .and. keys(k)%nval == 2) then
                ! a 1D mesh uses component 1 only: a nonzero second would be dropped unseen
                if (keys(k)%v(2) /= 0.0_dp) then
                    msg = key_ctx(name, keys(k))//': expected 1 value in 1D, or 2 whose '// &
                          'second is 0 (a 1D mesh uses component 1 only; got '''// &
                          shown(keys(k)%text, VALUE_LEN)//''')'
                    return
                end if
            end if
        end do
    end subroutine vector_dims

    ! ---------------------------------------------------------------- helpers

    !> 'NAME: &group key: what (got 'VALUE')', VALUE as written (a string unquoted).
    pure function bad(keys, name, group, key, what) result(s)
        type(key_t), intent(in) :: keys(:)        !! the table
        character(len=*), intent(in) :: name      !! scene name
        character(len=*), intent(in) :: group     !! group of the key
        character(len=*), intent(in) :: key       !! the key
        character(len=*), intent(in) :: what      !! what is wrong
        character(len=:), allocatable :: s
        integer :: k
        k = key_index(keys, group, key)
        s = keys(k)%text
        if (associated(keys(k)%s)) s = trim(keys(k)%s)
        s = key_ctx(name, keys(k))//': '//what//' (got '''//shown(s, VALUE_LEN)//''')'
    end function bad

    !> "&scheme name = 'pc' is explicit in its contact" ("is explicit" for central): why a
    !> method or mass that needs an implicit scheme is refused.
    pure function explicit_text(scheme) result(s)
        character(len=*), intent(in) :: scheme  !! an explicit scheme's name
        character(len=:), allocatable :: s
        s = '&scheme name = '''//trim(scheme)//''' is explicit'
        if (trim(scheme) /= 'central') s = s//' in its contact'
    end function explicit_text

    !> 'NAME: &group key'
    pure function key_ctx(name, key) result(s)
        character(len=*), intent(in) :: name   !! scene name
        type(key_t), intent(in) :: key         !! the key
        character(len=:), allocatable :: s
        s = name//': &'//trim(key%group)//' '//trim(key%name)
    end function key_ctx

    !> Index of key `name` of `group` in the table, or of the group's first key if
    !> name = ''; 0 if unknown.
    pure integer function key_index(keys, group, name)
        type(key_t), intent(in) :: keys(:)     !! the table
        character(len=*), intent(in) :: group  !! group name
        character(len=*), intent(in) :: name   !! key name
        integer :: k
        key_index = 0
        if (len(group) > len(keys(1)%group) .or. len(name) > len(keys(1)%name)) return
        do k = size(keys), 1, -1
            if (keys(k)%group == group .and. (keys(k)%name == name .or. name == '')) &
                key_index = k
        end do
    end function key_index

    !> The keys of `group`, or ('') the groups, comma-separated.
    pure function names(keys, group) result(s)
        type(key_t), intent(in) :: keys(:)     !! the table
        character(len=*), intent(in) :: group  !! group name, '' = list the groups
        character(len=:), allocatable :: s
        integer :: k
        s = ''
        do k = 1, size(keys)
            if (len(group) == 0 .and. key_index(keys, keys(k)%group, '') == k) then
                s = s//', &'//trim(keys(k)%group)
            else if (len(group) > 0 .and. keys(k)%group == group) then
                s = s//', '//trim(keys(k)%name)
            end if
        end do
        s = s(3:)
    end function names

    !> Advance i over blanks, line breaks and `!` comments.
    pure subroutine skip_blanks(text, i)
        character(len=*), intent(in) :: text   !! scene text
        integer, intent(inout) :: i            !! position
        do while (i <= len(text))
            if (text(i:i) == '!') then
                i = i + index(text(i:)//achar(10), achar(10)) - 1
            else if (index(BLANKS, text(i:i)) > 0) then
                i = i + 1
            else
                exit
            end if
        end do
    end subroutine skip_blanks

    !> Position after the identifier ([A-Za-z][A-Za-z0-9_]*) starting at i (i if none).
    pure integer function ident_end(text, i) result(j)
        character(len=*), intent(in) :: text   !! scene text
        integer, intent(in) :: i               !! start
        character(len=*), parameter :: LETTERS = &
            'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ'
        j = i
        if (i > len(text)) return
        if (index(LETTERS, text(i:i)) == 0) return
        j = verify(text(i:), LETTERS//'0123456789_')
        j = merge(len(text) + 1, i + j - 1, j == 0)
    end function ident_end

    !> Position after the quoted string starting at text(i:i); 0 if it does not end on its line.
    pure integer function string_end(text, i) result(j)
        character(len=*), intent(in) :: text   !! scene text
        integer, intent(in) :: i               !! position of the opening quote
        j = i + 1
        do while (j <= len(text))
            if (text(j:j) == achar(10) .or. text(j:j) == achar(13)) exit
            if (text(j:j) == text(i:i)) then
                if (text(j + 1:min(j + 1, len(text))) /= text(i:i) .or. j == len(text)) then
                    j = j + 1
                    return
                end if
                j = j + 1    ! a doubled quote
            end if
            j = j + 1
        end do
        j = 0
    end function string_end

    !> Line number of position i.
    pure integer function line_of(text, i)
        character(len=*), intent(in) :: text   !! scene text
        integer, intent(in) :: i               !! position
        integer :: p
        line_of = 1
        do p = 1, min(i, len(text)) - 1
            if (text(p:p) == achar(10)) line_of = line_of + 1
        end do
    end function line_of

    !> " (got 'TEXT')", TEXT = the scene text from i to the end of its line, shortened.
    pure function got(text, i) result(s)
        character(len=*), intent(in) :: text   !! scene text
        integer, intent(in) :: i               !! start
        character(len=:), allocatable :: s
        integer :: j
        j = scan(text(min(i, len(text) + 1):)//achar(10), achar(10)//achar(13))
        s = ' (got '''//shown(trim(text(min(i, len(text) + 1):i + j - 2)))//''')'
    end function got

    !> Printable ASCII only ('?' for other bytes), at most maxlen (default EXCERPT_LEN)
    !> characters + '...'.
    pure function shown(s, maxlen) result(r)
        character(len=*), intent(in) :: s              !! text
        integer, intent(in), optional :: maxlen        !! longest kept
        character(len=:), allocatable :: r
        integer :: i, n
        n = EXCERPT_LEN
        if (present(maxlen)) n = maxlen
        r = s(1:min(len(s), n))
        do i = 1, len(r)
            if (iachar(r(i:i)) < 32 .or. iachar(r(i:i)) > 126) r(i:i) = '?'
        end do
        if (len(s) > n) r = r//'...'
    end function shown

    !> The number written in a check: a real or a fraction 'a/b'.
    pure real(dp) function number(s)
        character(len=*), intent(in) :: s   !! text
        real(dp) :: den
        integer :: p
        p = index(s//'/', '/')
        den = 1.0_dp
        if (p <= len(s)) read (s(p + 1:), *) den
        read (s(1:p - 1), *) number
        number = number / den
    end function number
end module scene
