!> Scene files (SPEC section 3): Fortran-namelist-format text read with a
!> tokenizer of our own, so that every error names the file, group and key.
!>
!> Grammar accepted (python/dyncontact/scene.py implements the same one):
!> - the file is text (no control byte other than tab, CR, LF), at most
!>   MAX_FILE_BYTES long, with at least one group;
!> - outside groups only blanks and `!` comments; a group is `&name ... /`,
!>   known names only, each at most once;
!> - inside a group: `key = value[, value ...]` pairs (keys case-insensitive,
!>   values separated by commas and/or blanks, line breaks and `!` comments
!>   anywhere between tokens); strings are quoted with ' or " (a doubled quote
!>   stands for itself, no line break inside); `r*value` repeats an unquoted value.
module scene
    use kinds, only: dp, i8
    use errors, only: STAT_OK, STAT_BAD_INPUT, raise
    implicit none
    private

    integer, parameter, public :: PATH_LEN = 1024  !! length of path strings
    integer, parameter, public :: NAME_LEN = 256   !! length of name strings

    !> A parsed scene with every default filled in (SPEC section 3).
    type, public :: scene_t
        character(len=PATH_LEN) :: path = ''              !! the scene file read ('' if built in code)
        ! &mesh
        character(len=PATH_LEN) :: mesh_file = ''         !! resolved .msh path ('' = built-in bar)
        integer :: mesh_dim = 2                           !! built-in bar dimension
        real(dp) :: mesh_length = 1.0_dp                  !! built-in bar length
        real(dp) :: mesh_width = 0.1_dp                   !! built-in bar width (2D)
        real(dp) :: mesh_h = 0.05_dp                      !! built-in bar mesh size
        ! &boundary
        character(len=NAME_LEN) :: clamped = 'top'        !! groups with u = 0
        character(len=NAME_LEN) :: slip_x = ''            !! groups with u_x = 0
        character(len=NAME_LEN) :: slip_y = ''            !! groups with u_y = 0
        character(len=NAME_LEN) :: contact = 'bottom'     !! contact boundary groups ('' = none)
        ! &material
        real(dp) :: young = 2.0_dp / 3.0_dp               !! Young's modulus E > 0
        real(dp) :: poisson = 1.0_dp / 3.0_dp             !! Poisson ratio in (-1, 1/2)
        real(dp) :: density = 1.0_dp                      !! rho > 0
        real(dp) :: gravity(2) = 0.0_dp                   !! body acceleration g (f = rho g)
        ! &contact
        character(len=NAME_LEN) :: contact_method = 'nitsche' !! only 'nitsche'
        integer :: nitsche_theta = 1                      !! -1, 0 or 1
        real(dp) :: gamma0 = 10.0_dp                      !! gamma_N = gamma0 / h_T, > 0
        real(dp) :: obstacle_point(2) = 0.0_dp            !! a point of the obstacle plane
        real(dp) :: obstacle_normal(2) = [0.0_dp, -1.0_dp] !! body's outward normal (into obstacle), normalized on read
        real(dp) :: probe(2) = [0.05_dp, 0.0_dp]          !! probe point on Gamma_C
        character(len=NAME_LEN) :: quadrature = 'exact'   !! 'exact' (facet split at the kink) or 'gauss'
        integer :: quad_points = 3                        !! Gauss points per facet for 'gauss' (1..6)
        ! &initial
        character(len=NAME_LEN) :: initial_kind = 'compressed_bar' !! 'rest' | 'velocity' | 'compressed_bar'
        real(dp) :: amplitude = 0.5_dp                    !! compressed_bar lift
        real(dp) :: velocity(2) = 0.0_dp                  !! 'velocity' initial velocity
        ! &scheme
        character(len=NAME_LEN) :: scheme_name = 'hht'    !! newmark|hht|hht_seed|theta|pc|pc_hht|pc_hht_seed
        real(dp) :: alpha = 0.0_dp                        !! HHT alpha
        real(dp) :: beta = 0.25_dp                        !! Newmark / pc beta
        real(dp) :: gamma = 0.5_dp                        !! Newmark / pc gamma
        real(dp) :: time_theta = 0.5_dp                   !! theta-scheme theta in [1/2, 1]
        real(dp) :: rho_inf = 1.0_dp                      !! galpha spectral radius at infinity, [0, 1]
        real(dp) :: dt = 0.0025_dp                        !! time step > 0
        real(dp) :: t_end = 15.0_dp                       !! final time >= 0
        character(len=NAME_LEN) :: mass = 'consistent'    !! 'consistent' | 'lumped'
        real(dp) :: newton_tol = 1.0e-10_dp               !! relative residual tolerance
        integer :: newton_maxit = 50                      !! max Newton iterations > 0
        real(dp) :: blowup = 10.0_dp                      !! unstable when e_total > blowup * e_total(0)
        ! &output
        character(len=PATH_LEN) :: out_dir = 'out'        !! output folder
        integer :: every = 1                              !! trace row every this many steps
        integer :: fields_every = 0                       !! VTU snapshot every this many steps (0 = none)
    end type scene_t

    public :: scene_read, scene_to_json

    ! ---- the key table (same order as SCHEMA in python/dyncontact/scene.py) ----
    integer, parameter :: T_INT = 1, T_REAL = 2, T_VEC = 3, T_NAME = 4, T_PATH = 5
    integer, parameter :: N_GROUPS = 7, N_KEYS = 38
    character(len=8), parameter :: GROUP_NAMES(N_GROUPS) = [character(len=8) :: &
        'mesh', 'boundary', 'material', 'contact', 'initial', 'scheme', 'output']
    character(len=16), parameter :: KEY_NAMES(N_KEYS) = [character(len=16) :: &
        'file', 'dim', 'length', 'width', 'h', &
        'clamped', 'slip_x', 'slip_y', 'contact', &
        'young', 'poisson', 'density', 'gravity', &
        'method', 'theta', 'gamma0', 'obstacle_point', 'obstacle_normal', 'probe', &
        'quadrature', 'quad_points', &
        'kind', 'amplitude', 'velocity', &
        'name', 'alpha', 'beta', 'gamma', 'theta', 'dt', 't_end', 'mass', &
        'newton_tol', 'newton_maxit', 'blowup', &
        'dir', 'every', 'fields_every']
    integer, parameter :: KEY_GROUP(N_KEYS) = [1, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, &
        4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 7, 7, 7]
    integer, parameter :: KEY_TYPE(N_KEYS) = [ &
        T_PATH, T_INT, T_REAL, T_REAL, T_REAL, &
        T_NAME, T_NAME, T_NAME, T_NAME, &
        T_REAL, T_REAL, T_REAL, T_VEC, &
        T_NAME, T_INT, T_REAL, T_VEC, T_VEC, T_VEC, T_NAME, T_INT, &
        T_NAME, T_REAL, T_VEC, &
        T_NAME, T_REAL, T_REAL, T_REAL, T_REAL, T_REAL, T_REAL, T_NAME, T_REAL, T_INT, T_REAL, &
        T_PATH, T_INT, T_INT]

    integer, parameter :: MAX_FILE_BYTES = 1048576  !! larger files are rejected
    integer, parameter :: MAX_TOKENS = 8            !! raw tokens kept per key (for messages)
    integer, parameter :: MAX_REPEAT = 1000         !! repeat counts are capped at this for counting
    integer, parameter :: EXCERPT_LEN = 40          !! characters of file text quoted in messages
    integer, parameter :: VALUE_LEN = 200           !! characters of a value quoted in messages
    character(len=1), parameter :: TAB = achar(9), LF = achar(10), CR = achar(13)

    !> One value token as written in the file.
    type :: token_t
        character(len=:), allocatable :: raw    !! text as written (quotes, repeat count included)
        character(len=:), allocatable :: value  !! unquoted string, or the value after `r*`
        logical :: quoted = .false.             !! a quoted string
        integer :: rep = 1                      !! repeat count (capped at MAX_REPEAT)
    end type token_t

    !> The tokens given for one key.
    type :: entry_t
        logical :: given = .false.              !! the key appears in the file
        integer :: nval = 0                     !! number of values (repeats expanded, capped)
        integer :: ntok = 0                     !! tokens stored (at most MAX_TOKENS)
        type(token_t) :: tok(MAX_TOKENS)        !! the first tokens
    end type entry_t

contains

    !> Read and validate the scene file `path` (SPEC section 3). Groups may come in
    !> any order and each at most once; missing groups keep their defaults. A
    !> relative mesh_file is resolved against the scene file's folder. Errors give
    !> STAT_BAD_INPUT and one line "PATH: &group key: what is wrong".
    subroutine scene_read(path, scn, stat, errmsg)
        character(len=*), intent(in) :: path                !! scene file
        type(scene_t), intent(out) :: scn                   !! parsed scene
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=:), allocatable :: text, msg
        type(entry_t) :: entries(N_KEYS)
        integer :: k

        scn%path = path
        msg = ''
        call read_text(trim(path), text, msg)
        if (len(msg) == 0) call tokenize(trim(path), text, entries, msg)
        if (len(msg) == 0) then
            do k = 1, N_KEYS
                if (.not. entries(k)%given) cycle
                call set_key(trim(path), k, entries(k), scn, msg)
                if (len(msg) > 0) exit
            end do
        end if
        if (len(msg) == 0) call validate(trim(path), scn, msg)
        if (len(msg) > 0) then
            call raise(stat, errmsg, STAT_BAD_INPUT, msg)
            return
        end if
        stat = STAT_OK
    end subroutine scene_read

    !> The scene as a JSON object {"mesh": {...}, "boundary": {...}, ...} with the
    !> namelist key names of SPEC section 3 (contact theta is "theta" in "contact").
    !> Reals are written in their shortest round-trip form; 2-vectors as lists.
    function scene_to_json(scn) result(json)
        type(scene_t), intent(in) :: scn    !! scene
        character(len=:), allocatable :: json
        integer :: k, g
        json = '{'
        g = 0
        do k = 1, N_KEYS
            if (KEY_GROUP(k) /= g) then
                if (g > 0) json = json//'}, '
                g = KEY_GROUP(k)
                json = json//'"'//trim(GROUP_NAMES(g))//'": {'
            else
                json = json//', '
            end if
            json = json//'"'//trim(KEY_NAMES(k))//'": '//key_json(scn, k)
        end do
        json = json//'}}'
    end function scene_to_json

    ! ------------------------------------------------------------------ reading

    !> Whole file into `text`; msg /= '' on a missing, unreadable, empty, too large
    !> or non-text file.
    subroutine read_text(path, text, msg)
        character(len=*), intent(in) :: path                 !! scene file
        character(len=:), allocatable, intent(out) :: text   !! its bytes
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        integer :: unit, ios, n, i, line, c
        character(len=256) :: iomsg
        character(len=32) :: buf

        text = ''
        if (len(path) == 0) then
            msg = ': cannot read scene file (empty path)'
            return
        end if
        open (newunit=unit, file=path, access='stream', form='unformatted', action='read', &
              status='old', iostat=ios, iomsg=iomsg)
        if (ios /= 0) then
            msg = path//': cannot read scene file'
            return
        end if
        inquire (unit=unit, size=n, iostat=ios)
        if (ios /= 0 .or. n < 0) then
            close (unit, iostat=ios)
            msg = path//': cannot read scene file'
            return
        end if
        if (n > MAX_FILE_BYTES) then
            close (unit, iostat=ios)
            write (buf, '(i0)') MAX_FILE_BYTES
            msg = path//': scene file too large (more than '//trim(buf)//' bytes)'
            return
        end if
        deallocate (text)
        allocate (character(len=n) :: text, stat=ios)
        if (ios /= 0) then
            close (unit, iostat=ios)
            msg = path//': cannot read scene file'
            return
        end if
        if (n > 0) read (unit, iostat=ios, iomsg=iomsg) text
        close (unit, iostat=i)
        if (ios /= 0) then
            msg = path//': cannot read scene file'
            return
        end if
        if (n == 0) then
            msg = path//': empty scene file'
            return
        end if
        line = 1
        do i = 1, n
            c = iachar(text(i:i))
            if (c == 10) line = line + 1
            if ((c < 32 .and. c /= 9 .and. c /= 10 .and. c /= 13) .or. c == 127) then
                write (buf, '(i0)') line
                msg = path//': not a text file (control character on line '//trim(buf)//')'
                return
            end if
        end do
    end subroutine read_text

    !> Split `text` into groups and key = value entries (see the module header).
    subroutine tokenize(path, text, entries, msg)
        character(len=*), intent(in) :: path                 !! scene file (for messages)
        character(len=*), intent(in) :: text                 !! file contents
        type(entry_t), intent(inout) :: entries(N_KEYS)      !! tokens per key
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        integer :: i, j, n, line, g, k, seen(N_GROUPS), ngroups
        character(len=:), allocatable :: gname, key, gtxt
        character(len=32) :: buf, buf2
        logical :: closed

        gname = ''; key = ''; gtxt = ''
        n = len(text)
        i = 1
        line = 1
        seen = 0
        ngroups = 0
        do
            call skip_space(text, i, line)
            if (i > n) exit
            if (text(i:i) /= '&') then
                write (buf, '(i0)') line
                msg = path//': line '//trim(buf)//': text outside a group (got '''// &
                      excerpt(text, i)//''')'
                return
            end if
            j = ident_end(text, i + 1)
            if (j == i + 1) then
                write (buf, '(i0)') line
                msg = path//': line '//trim(buf)//': ''&'' without a group name (got '''// &
                      excerpt(text, i)//''')'
                return
            end if
            gname = sanitize(lower(text(i + 1:j - 1)), EXCERPT_LEN)
            g = group_index(gname)
            gtxt = path//': &'//gname
            if (g == 0) then
                msg = gtxt//': unknown group (expected one of '//group_list()//')'
                return
            end if
            if (seen(g) > 0) then
                write (buf, '(i0)') seen(g)
                write (buf2, '(i0)') line
                msg = gtxt//': group given twice (lines '//trim(buf)//' and '//trim(buf2)//')'
                return
            end if
            seen(g) = line
            ngroups = ngroups + 1
            i = j
            if (i <= n) then
                if (index(' '//TAB//CR//LF//'/!', text(i:i)) == 0) then
                    msg = gtxt//': expected a blank after the group name (got '''// &
                          excerpt(text, i)//''')'
                    return
                end if
            end if
            ! the group's body
            closed = .false.
            do
                call skip_space(text, i, line)
                if (i > n) exit
                if (text(i:i) == '/') then
                    i = i + 1
                    closed = .true.
                    exit
                end if
                if (text(i:i) == '&') exit
                j = ident_end(text, i)
                if (j == i) then
                    msg = gtxt//': expected a key name (got '''//excerpt(text, i)//''')'
                    return
                end if
                key = sanitize(lower(text(i:j - 1)), EXCERPT_LEN)
                k = key_index(g, key)
                if (k == 0) then
                    msg = gtxt//' '//key//': unknown key (expected one of '//key_list(g)//')'
                    return
                end if
                if (entries(k)%given) then
                    msg = gtxt//' '//key//': key given twice'
                    return
                end if
                i = j
                call skip_space(text, i, line)
                if (i > n) exit
                if (text(i:i) /= '=') then
                    msg = gtxt//' '//key//': expected ''='' after the key (got '''// &
                          excerpt(text, i)//''')'
                    return
                end if
                i = i + 1
                entries(k)%given = .true.
                call read_values(text, i, line, entries(k), gtxt//' '//key, msg)
                if (len(msg) > 0) return
            end do
            if (.not. closed) then
                if (i > n) then
                    msg = gtxt//': unterminated group (no ''/'' before the end of the file)'
                else
                    msg = gtxt//': unterminated group (no ''/'' before '''// &
                          excerpt(text, i)//''')'
                end if
                return
            end if
        end do
        if (ngroups == 0) msg = path//': empty scene file (no &group)'
    end subroutine tokenize

    !> The values of one key, from just after its '=' up to the next key, '/' or '&'.
    subroutine read_values(text, i, line, entry, ctx, msg)
        character(len=*), intent(in) :: text                 !! file contents
        integer, intent(inout) :: i                          !! position
        integer, intent(inout) :: line                       !! line number at i
        type(entry_t), intent(inout) :: entry                !! tokens of the key
        character(len=*), intent(in) :: ctx                !! 'PATH: &group key'
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        integer :: n, j, start, iline, p
        logical :: expect
        type(token_t) :: tok

        n = len(text)
        expect = .true.
        do
            call skip_space(text, i, line)
            if (i > n) exit
            select case (text(i:i))
            case ('/', '&')
                exit
            case (',')
                if (expect) then
                    msg = ctx//': empty value (got '''//excerpt(text, i)//''')'
                    return
                end if
                expect = .true.
                i = i + 1
                cycle
            case ('=')
                msg = ctx//': unexpected ''='' (got '''//excerpt(text, i)//''')'
                return
            case ('''', '"')
                call read_quoted(text, i, j, tok)
                if (j == 0) then
                    msg = ctx//': unterminated string (got '''//excerpt(text, i)//''')'
                    return
                end if
                if (j <= n) then
                    if (index(' '//TAB//CR//LF//',/!', text(j:j)) == 0) then
                        msg = ctx//': unexpected text after a string (got '''// &
                              excerpt(text, i)//''')'
                        return
                    end if
                end if
                i = j
            case default
                start = i
                j = i
                do while (j <= n)
                    if (index(' '//TAB//CR//LF//',/!=', text(j:j)) > 0) exit
                    j = j + 1
                end do
                ! an identifier followed by '=' is the next key
                if (ident_end(text, start) == j) then
                    p = j
                    iline = line
                    call skip_space(text, p, iline)
                    if (p <= n) then
                        if (text(p:p) == '=') exit
                    end if
                end if
                tok%raw = text(start:j - 1)
                tok%quoted = .false.
                tok%rep = 1
                tok%value = tok%raw
                call split_repeat(tok, ctx, msg)
                if (len(msg) > 0) return
                i = j
            end select
            entry%nval = min(entry%nval + tok%rep, MAX_TOKENS * MAX_REPEAT)
            if (entry%ntok < MAX_TOKENS) then
                entry%ntok = entry%ntok + 1
                entry%tok(entry%ntok) = tok
            end if
            expect = .false.
        end do
        if (entry%nval == 0) then
            if (i > n) then
                msg = ctx//': missing value (got '''')'
            else
                msg = ctx//': missing value (got '''//excerpt(text, i)//''')'
            end if
        end if
    end subroutine read_values

    !> A quoted string starting at text(i:i); j = position after it, 0 if unterminated.
    subroutine read_quoted(text, i, j, tok)
        character(len=*), intent(in) :: text    !! file contents
        integer, intent(in) :: i                !! position of the opening quote
        integer, intent(out) :: j               !! position after the closing quote, 0 if none
        type(token_t), intent(out) :: tok       !! the string
        character(len=1) :: q
        character(len=:), allocatable :: buf
        integer :: n, m, p
        n = len(text)
        q = text(i:i)
        j = 0
        ! find the closing quote
        p = i + 1
        do while (p <= n)
            if (text(p:p) == LF .or. text(p:p) == CR) return
            if (text(p:p) == q) then
                if (p < n) then
                    if (text(p + 1:p + 1) == q) then
                        p = p + 2
                        cycle
                    end if
                end if
                j = p + 1
                exit
            end if
            p = p + 1
        end do
        if (j == 0) return
        allocate (character(len=j - i) :: buf)
        m = 0
        p = i + 1
        do while (p < j - 1)
            m = m + 1
            buf(m:m) = text(p:p)
            if (text(p:p) == q) p = p + 1    ! doubled quote
            p = p + 1
        end do
        tok%raw = text(i:j - 1)
        tok%value = buf(1:m)
        tok%quoted = .true.
        tok%rep = 1
    end subroutine read_quoted

    !> Split an unquoted `r*value` token into its repeat count and value.
    subroutine split_repeat(tok, ctx, msg)
        type(token_t), intent(inout) :: tok                  !! unquoted token
        character(len=*), intent(in) :: ctx                !! 'PATH: &group key'
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        integer :: p, r, ios
        p = index(tok%raw, '*')
        if (p < 2) return
        if (verify(tok%raw(1:p - 1), '0123456789') /= 0) return
        if (p == len(tok%raw)) then
            msg = ctx//': empty value (got '''//sanitize(tok%raw, VALUE_LEN)//''')'
            return
        end if
        if (p - 1 > 6) then
            r = MAX_REPEAT
        else
            read (tok%raw(1:p - 1), *, iostat=ios) r
            if (ios /= 0) r = 0
        end if
        if (r == 0) then
            msg = ctx//': repeat count must be > 0 (got '''//sanitize(tok%raw, VALUE_LEN)//''')'
            return
        end if
        tok%rep = min(r, MAX_REPEAT)
        tok%value = tok%raw(p + 1:)
    end subroutine split_repeat

    !> Advance i over blanks, line breaks and `!` comments.
    subroutine skip_space(text, i, line)
        character(len=*), intent(in) :: text   !! file contents
        integer, intent(inout) :: i            !! position
        integer, intent(inout) :: line         !! line number at i
        integer :: n
        n = len(text)
        do while (i <= n)
            select case (text(i:i))
            case (LF)
                line = line + 1
                i = i + 1
            case (' ', TAB, CR)
                i = i + 1
            case ('!')
                do while (i <= n)
                    if (text(i:i) == LF) exit
                    i = i + 1
                end do
            case default
                exit
            end select
        end do
    end subroutine skip_space

    !> Position after the identifier ([A-Za-z][A-Za-z0-9_]*) starting at i (i if none).
    pure function ident_end(text, i) result(j)
        character(len=*), intent(in) :: text   !! file contents
        integer, intent(in) :: i               !! start
        integer :: j
        j = i
        if (i > len(text)) return
        if (.not. is_letter(text(i:i))) return
        j = i + 1
        do while (j <= len(text))
            if (.not. (is_letter(text(j:j)) .or. is_digit(text(j:j)) .or. text(j:j) == '_')) exit
            j = j + 1
        end do
    end function ident_end

    ! ------------------------------------------------------------ conversion

    !> Convert the tokens of key k into its scene_t field.
    subroutine set_key(path, k, entry, scn, msg)
        character(len=*), intent(in) :: path                 !! scene file
        integer, intent(in) :: k                             !! key index
        type(entry_t), intent(in) :: entry                   !! its tokens
        type(scene_t), intent(inout) :: scn                  !! scene
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        character(len=:), allocatable :: ctx, s
        integer :: iv
        real(dp) :: x, v(2)

        s = ''; iv = 0; x = 0.0_dp; v = 0.0_dp
        ctx = path//': &'//trim(GROUP_NAMES(KEY_GROUP(k)))//' '//trim(KEY_NAMES(k))
        if (KEY_TYPE(k) == T_VEC) then
            if (entry%nval > 2) then
                msg = ctx//': expected 1 or 2 values (got '''//joined(entry)//''')'
                return
            end if
        else if (entry%nval /= 1) then
            msg = ctx//': expected 1 value (got '''//joined(entry)//''')'
            return
        end if
        select case (KEY_TYPE(k))
        case (T_INT)
            call get_int(entry%tok(1), ctx, iv, msg)
        case (T_REAL)
            call get_real(entry%tok(1), ctx, x, msg)
        case (T_VEC)
            call get_real(entry%tok(1), ctx, v(1), msg)
            if (len(msg) > 0) return
            if (entry%nval == 1) then
                v(2) = 0.0_dp
            else if (entry%tok(1)%rep == 2) then
                v(2) = v(1)
            else
                call get_real(entry%tok(2), ctx, v(2), msg)
            end if
        case (T_NAME, T_PATH)
            call get_string(entry%tok(1), ctx, merge(PATH_LEN, NAME_LEN, KEY_TYPE(k) == T_PATH), &
                            s, msg)
        end select
        if (len(msg) > 0) return
        select case (k)
        case (1); scn%mesh_file = s
        case (2); scn%mesh_dim = iv
        case (3); scn%mesh_length = x
        case (4); scn%mesh_width = x
        case (5); scn%mesh_h = x
        case (6); scn%clamped = s
        case (7); scn%slip_x = s
        case (8); scn%slip_y = s
        case (9); scn%contact = s
        case (10); scn%young = x
        case (11); scn%poisson = x
        case (12); scn%density = x
        case (13); scn%gravity = v
        case (14); scn%contact_method = s
        case (15); scn%nitsche_theta = iv
        case (16); scn%gamma0 = x
        case (17); scn%obstacle_point = v
        case (18); scn%obstacle_normal = v
        case (19); scn%probe = v
        case (20); scn%quadrature = s
        case (21); scn%quad_points = iv
        case (22); scn%initial_kind = s
        case (23); scn%amplitude = x
        case (24); scn%velocity = v
        case (25); scn%scheme_name = s
        case (26); scn%alpha = x
        case (27); scn%beta = x
        case (28); scn%gamma = x
        case (29); scn%time_theta = x
        case (30); scn%dt = x
        case (31); scn%t_end = x
        case (32); scn%mass = s
        case (33); scn%newton_tol = x
        case (34); scn%newton_maxit = iv
        case (35); scn%blowup = x
        case (36); scn%out_dir = s
        case (37); scn%every = iv
        case (38); scn%fields_every = iv
        end select
    end subroutine set_key

    !> An integer: unquoted, [+-]digits, within the default integer range.
    subroutine get_int(tok, ctx, iv, msg)
        type(token_t), intent(in) :: tok                     !! token
        character(len=*), intent(in) :: ctx                !! 'PATH: &group key'
        integer, intent(out) :: iv                           !! value
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        integer :: ios, s
        integer(i8) :: big
        iv = 0
        big = 0
        if (tok%quoted) then
            msg = ctx//': expected an integer, not a string (got '''// &
                  sanitize(tok%raw, VALUE_LEN)//''')'
            return
        end if
        if (.not. is_integer(tok%value)) then
            msg = ctx//': expected an integer (got '''//sanitize(tok%raw, VALUE_LEN)//''')'
            return
        end if
        s = 1
        if (scan(tok%value(1:1), '+-') > 0) s = 2
        ! more than 18 digits (leading zeros included) is out of range
        ios = 1
        if (len(tok%value) - s + 1 <= 18) read (tok%value(s:), *, iostat=ios) big
        if (tok%value(1:1) == '-') big = -big
        if (ios /= 0 .or. big > huge(iv) .or. big < -huge(iv) - 1) then
            msg = ctx//': integer out of range (got '''//sanitize(tok%raw, VALUE_LEN)//''')'
            return
        end if
        iv = int(big)
    end subroutine get_int

    !> A real: unquoted, Fortran literal form (1, 1.0, .5, 1e-3, 1d-3), finite.
    subroutine get_real(tok, ctx, x, msg)
        type(token_t), intent(in) :: tok                     !! token
        character(len=*), intent(in) :: ctx                !! 'PATH: &group key'
        real(dp), intent(out) :: x                           !! value
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        integer :: ios
        x = 0.0_dp
        if (tok%quoted) then
            msg = ctx//': expected a real number, not a string (got '''// &
                  sanitize(tok%raw, VALUE_LEN)//''')'
            return
        end if
        if (.not. is_real(tok%value)) then
            msg = ctx//': expected a real number (got '''//sanitize(tok%raw, VALUE_LEN)//''')'
            return
        end if
        read (tok%value, *, iostat=ios) x
        if (ios /= 0 .or. .not. (abs(x) <= huge(x))) then
            x = 0.0_dp
            msg = ctx//': real number out of range (got '''//sanitize(tok%raw, VALUE_LEN)//''')'
        end if
    end subroutine get_real

    !> A quoted string of at most maxlen characters (trailing blanks dropped).
    subroutine get_string(tok, ctx, maxlen, s, msg)
        type(token_t), intent(in) :: tok                     !! token
        character(len=*), intent(in) :: ctx                !! 'PATH: &group key'
        integer, intent(in) :: maxlen                        !! longest allowed
        character(len=:), allocatable, intent(out) :: s      !! value
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        character(len=16) :: buf
        s = ''
        if (.not. tok%quoted) then
            msg = ctx//': expected a quoted string (got '''//sanitize(tok%raw, VALUE_LEN)//''')'
            return
        end if
        if (len_trim(tok%value) > maxlen) then
            write (buf, '(i0)') maxlen
            msg = ctx//': string too long (more than '//trim(buf)//' characters)'
            return
        end if
        s = trim(tok%value)
    end subroutine get_string

    !> Integer literal syntax: [+-]digits.
    pure logical function is_integer(s)
        character(len=*), intent(in) :: s   !! text
        integer :: i0
        i0 = 1
        if (len(s) > 0) then
            if (scan(s(1:1), '+-') > 0) i0 = 2
        end if
        is_integer = len(s) >= i0 .and. verify(s(i0:), '0123456789') == 0
    end function is_integer

    !> Real literal syntax: [+-] (digits [. [digits]] | . digits) [(e|E|d|D) [+-] digits].
    pure logical function is_real(s)
        character(len=*), intent(in) :: s   !! text
        integer :: i, n, nm
        is_real = .false.
        n = len(s)
        i = 1
        if (n == 0) return
        if (scan(s(1:1), '+-') > 0) i = 2
        nm = 0
        do while (i <= n)
            if (.not. is_digit(s(i:i))) exit
            nm = nm + 1
            i = i + 1
        end do
        if (i <= n) then
            if (s(i:i) == '.') then
                i = i + 1
                do while (i <= n)
                    if (.not. is_digit(s(i:i))) exit
                    nm = nm + 1
                    i = i + 1
                end do
            end if
        end if
        if (nm == 0) return
        if (i > n) then
            is_real = .true.
            return
        end if
        if (scan(s(i:i), 'eEdD') == 0) return
        i = i + 1
        if (i <= n) then
            if (scan(s(i:i), '+-') > 0) i = i + 1
        end if
        if (i > n) return
        is_real = verify(s(i:), '0123456789') == 0
    end function is_real

    ! ------------------------------------------------------------ validation

    !> Range and consistency checks in key-table order; resolves mesh_file and
    !> normalizes obstacle_normal.
    subroutine validate(path, scn, msg)
        character(len=*), intent(in) :: path                 !! scene file
        type(scene_t), intent(inout) :: scn                  !! scene
        character(len=:), allocatable, intent(inout) :: msg  !! error ('' = none)
        character(len=:), allocatable :: resolved, name
        real(dp) :: nrm
        real(dp), parameter :: THIRD = 1.0_dp / 3.0_dp
        integer :: unit, ios

        name = trim(scn%scheme_name)
        ! &mesh
        if (len_trim(scn%mesh_file) > 0) then
            resolved = resolve_path(path, trim(scn%mesh_file))
            if (len(resolved) > PATH_LEN) then
                msg = key_ctx(path, 1)//': resolved path too long (got '''// &
                      sanitize(trim(scn%mesh_file), VALUE_LEN)//''')'
                return
            end if
            open (newunit=unit, file=resolved, access='stream', form='unformatted', &
                  action='read', status='old', iostat=ios)
            if (ios == 0) then
                block
                    character(len=1) :: c1
                    integer :: sz, ios2
                    inquire (unit=unit, size=sz, iostat=ios2)
                    if (ios2 == 0 .and. sz > 0) read (unit, iostat=ios) c1
                    close (unit, iostat=ios2)
                end block
            end if
            if (ios /= 0) then
                msg = key_ctx(path, 1)//': cannot read mesh file '''// &
                      sanitize(resolved, VALUE_LEN)//''' (got '''// &
                      sanitize(trim(scn%mesh_file), VALUE_LEN)//''')'
                return
            end if
            scn%mesh_file = resolved
        end if
        if (scn%mesh_dim /= 1 .and. scn%mesh_dim /= 2) then
            msg = bad(path, 2, 'must be 1 or 2', int_str(scn%mesh_dim)); return
        end if
        if (.not. scn%mesh_length > 0.0_dp) then
            msg = bad(path, 3, 'must be > 0', real_repr(scn%mesh_length)); return
        end if
        if (.not. scn%mesh_width > 0.0_dp) then
            msg = bad(path, 4, 'must be > 0', real_repr(scn%mesh_width)); return
        end if
        if (.not. scn%mesh_h > 0.0_dp) then
            msg = bad(path, 5, 'must be > 0', real_repr(scn%mesh_h)); return
        end if
        ! &material
        if (.not. scn%young > 0.0_dp) then
            msg = bad(path, 10, 'must be > 0', real_repr(scn%young)); return
        end if
        if (.not. (scn%poisson > -1.0_dp .and. scn%poisson < 0.5_dp)) then
            msg = bad(path, 11, 'must be in (-1, 1/2)', real_repr(scn%poisson)); return
        end if
        if (.not. scn%density > 0.0_dp) then
            msg = bad(path, 12, 'must be > 0', real_repr(scn%density)); return
        end if
        ! &contact
        if (scn%contact_method /= 'nitsche') then
            msg = bad(path, 14, 'must be ''nitsche''', trim(scn%contact_method)); return
        end if
        if (scn%nitsche_theta < -1 .or. scn%nitsche_theta > 1) then
            msg = bad(path, 15, 'must be -1, 0 or 1', int_str(scn%nitsche_theta)); return
        end if
        if (.not. scn%gamma0 > 0.0_dp) then
            msg = bad(path, 16, 'must be > 0', real_repr(scn%gamma0)); return
        end if
        if (scn%mesh_dim == 1) then
            if (scn%obstacle_normal(1) == 0.0_dp) then
                msg = bad(path, 18, 'component 1 must be nonzero in 1D', &
                          vec_str(scn%obstacle_normal)); return
            end if
            scn%obstacle_normal = [sign(1.0_dp, scn%obstacle_normal(1)), 0.0_dp]
        else
            nrm = sqrt(scn%obstacle_normal(1) * scn%obstacle_normal(1) &
                       + scn%obstacle_normal(2) * scn%obstacle_normal(2))
            if (.not. (nrm > 0.0_dp .and. nrm <= huge(nrm))) then
                msg = bad(path, 18, 'must be a nonzero vector', &
                          vec_str(scn%obstacle_normal)); return
            end if
            ! a normal already of unit length (to round-off) is kept as is, so that
            ! normalizing is idempotent and a written scene reads back the same
            if (abs(nrm - 1.0_dp) > 4.0_dp * epsilon(nrm)) &
                scn%obstacle_normal = scn%obstacle_normal / nrm
        end if
        if (scn%quadrature /= 'exact' .and. scn%quadrature /= 'gauss') then
            msg = bad(path, 20, 'must be ''exact'' or ''gauss''', trim(scn%quadrature)); return
        end if
        if (scn%quad_points < 1 .or. scn%quad_points > 6) then
            msg = bad(path, 21, 'must be in 1..6', int_str(scn%quad_points)); return
        end if
        ! &initial
        select case (trim(scn%initial_kind))
        case ('rest', 'velocity', 'compressed_bar')
        case default
            msg = bad(path, 22, 'must be one of ''rest'', ''velocity'', ''compressed_bar''', &
                      trim(scn%initial_kind)); return
        end select
        ! &scheme
        select case (name)
        case ('newmark', 'hht', 'hht_seed', 'theta', 'pc', 'pc_hht', 'pc_hht_seed')
        case default
            msg = bad(path, 25, 'must be one of ''newmark'', ''hht'', ''hht_seed'', ''theta'', '// &
                      '''pc'', ''pc_hht'', ''pc_hht_seed''', name); return
        end select
        if ((name == 'hht' .or. name == 'pc_hht') .and. &
            .not. (scn%alpha >= -THIRD .and. scn%alpha <= 0.0_dp)) then
            msg = bad(path, 26, 'must be in [-1/3, 0] for scheme '''//name//'''', &
                      real_repr(scn%alpha)); return
        end if
        if (name == 'newmark' .and. .not. scn%beta > 0.0_dp) then
            msg = bad(path, 27, 'must be > 0 for scheme ''newmark'' (explicit Newmark, '// &
                      'beta = 0, is not offered: use ''pc'')', real_repr(scn%beta)); return
        end if
        if (name == 'newmark' .and. .not. scn%gamma >= 0.0_dp) then
            msg = bad(path, 28, 'must be >= 0 for scheme ''newmark''', real_repr(scn%gamma)); return
        end if
        if (name == 'theta' .and. &
            .not. (scn%time_theta >= 0.5_dp .and. scn%time_theta <= 1.0_dp)) then
            msg = bad(path, 29, 'must be in [1/2, 1] for scheme ''theta''', &
                      real_repr(scn%time_theta)); return
        end if
        if (.not. scn%dt > 0.0_dp) then
            msg = bad(path, 30, 'must be > 0', real_repr(scn%dt)); return
        end if
        if (.not. scn%t_end >= 0.0_dp) then
            msg = bad(path, 31, 'must be >= 0', real_repr(scn%t_end)); return
        end if
        if (scn%mass /= 'consistent' .and. scn%mass /= 'lumped') then
            msg = bad(path, 32, 'must be ''consistent'' or ''lumped''', trim(scn%mass)); return
        end if
        if (.not. scn%newton_tol > 0.0_dp) then
            msg = bad(path, 33, 'must be > 0', real_repr(scn%newton_tol)); return
        end if
        if (scn%newton_maxit < 1) then
            msg = bad(path, 34, 'must be > 0', int_str(scn%newton_maxit)); return
        end if
        if (.not. scn%blowup > 1.0_dp) then
            msg = bad(path, 35, 'must be > 1', real_repr(scn%blowup)); return
        end if
        ! &output
        if (len_trim(scn%out_dir) == 0) then
            msg = bad(path, 36, 'must not be empty', ''); return
        end if
        if (scn%every < 1) then
            msg = bad(path, 37, 'must be > 0', int_str(scn%every)); return
        end if
        if (scn%fields_every < 0) then
            msg = bad(path, 38, 'must be >= 0', int_str(scn%fields_every)); return
        end if
    end subroutine validate

    !> 'PATH: &group key'
    function key_ctx(path, k) result(s)
        character(len=*), intent(in) :: path   !! scene file
        integer, intent(in) :: k               !! key index
        character(len=:), allocatable :: s
        s = path//': &'//trim(GROUP_NAMES(KEY_GROUP(k)))//' '//trim(KEY_NAMES(k))
    end function key_ctx

    !> 'PATH: &group key: what (got 'value')'
    function bad(path, k, what, got) result(s)
        character(len=*), intent(in) :: path   !! scene file
        integer, intent(in) :: k               !! key index
        character(len=*), intent(in) :: what   !! what is wrong
        character(len=*), intent(in) :: got    !! offending value
        character(len=:), allocatable :: s
        s = key_ctx(path, k)//': '//what//' (got '''//sanitize(got, VALUE_LEN)//''')'
    end function bad

    !> A relative `file` resolved against the folder of `scene_path` (as Python's
    !> os.path.join(os.path.dirname(scene_path), file)).
    function resolve_path(scene_path, file) result(res)
        character(len=*), intent(in) :: scene_path  !! scene file
        character(len=*), intent(in) :: file        !! path as written
        character(len=:), allocatable :: res
        character(len=:), allocatable :: head
        integer :: i, j
        if (file(1:1) == '/') then
            res = file
            return
        end if
        i = index(scene_path, '/', back=.true.)
        if (i == 0) then
            res = file
            return
        end if
        head = scene_path(1:i)
        if (verify(head, '/') /= 0) then
            j = len(head)
            do while (head(j:j) == '/')
                j = j - 1
            end do
            head = head(1:j)//'/'
        end if
        res = head//file
    end function resolve_path

    ! ------------------------------------------------------------ formatting

    !> JSON text of key k's value.
    function key_json(scn, k) result(s)
        type(scene_t), intent(in) :: scn    !! scene
        integer, intent(in) :: k            !! key index
        character(len=:), allocatable :: s
        select case (k)
        case (1); s = json_str(scn%mesh_file)
        case (2); s = int_str(scn%mesh_dim)
        case (3); s = real_repr(scn%mesh_length)
        case (4); s = real_repr(scn%mesh_width)
        case (5); s = real_repr(scn%mesh_h)
        case (6); s = json_str(scn%clamped)
        case (7); s = json_str(scn%slip_x)
        case (8); s = json_str(scn%slip_y)
        case (9); s = json_str(scn%contact)
        case (10); s = real_repr(scn%young)
        case (11); s = real_repr(scn%poisson)
        case (12); s = real_repr(scn%density)
        case (13); s = json_vec(scn%gravity)
        case (14); s = json_str(scn%contact_method)
        case (15); s = int_str(scn%nitsche_theta)
        case (16); s = real_repr(scn%gamma0)
        case (17); s = json_vec(scn%obstacle_point)
        case (18); s = json_vec(scn%obstacle_normal)
        case (19); s = json_vec(scn%probe)
        case (20); s = json_str(scn%quadrature)
        case (21); s = int_str(scn%quad_points)
        case (22); s = json_str(scn%initial_kind)
        case (23); s = real_repr(scn%amplitude)
        case (24); s = json_vec(scn%velocity)
        case (25); s = json_str(scn%scheme_name)
        case (26); s = real_repr(scn%alpha)
        case (27); s = real_repr(scn%beta)
        case (28); s = real_repr(scn%gamma)
        case (29); s = real_repr(scn%time_theta)
        case (30); s = real_repr(scn%dt)
        case (31); s = real_repr(scn%t_end)
        case (32); s = json_str(scn%mass)
        case (33); s = real_repr(scn%newton_tol)
        case (34); s = int_str(scn%newton_maxit)
        case (35); s = real_repr(scn%blowup)
        case (36); s = json_str(scn%out_dir)
        case (37); s = int_str(scn%every)
        case (38); s = int_str(scn%fields_every)
        case default; s = 'null'
        end select
    end function key_json

    !> JSON string literal of trim(s).
    function json_str(s) result(js)
        character(len=*), intent(in) :: s   !! text
        character(len=:), allocatable :: js
        character(len=:), allocatable :: buf
        character(len=6) :: u
        integer :: i, m, c
        allocate (character(len=6 * len_trim(s) + 2) :: buf)
        buf(1:1) = '"'
        m = 1
        do i = 1, len_trim(s)
            c = iachar(s(i:i))
            if (s(i:i) == '"' .or. s(i:i) == '\') then
                buf(m + 1:m + 2) = '\'//s(i:i)
                m = m + 2
            else if (c == 9) then
                buf(m + 1:m + 2) = '\t'
                m = m + 2
            else if (c < 32 .or. c == 127) then
                write (u, '(a, z4.4)') '\u', c
                buf(m + 1:m + 6) = u
                m = m + 6
            else
                buf(m + 1:m + 1) = s(i:i)
                m = m + 1
            end if
        end do
        buf(m + 1:m + 1) = '"'
        js = buf(1:m + 1)
    end function json_str

    !> '[a, b]' in shortest round-trip form.
    function json_vec(v) result(s)
        real(dp), intent(in) :: v(2)   !! vector
        character(len=:), allocatable :: s
        s = '['//real_repr(v(1))//', '//real_repr(v(2))//']'
    end function json_vec

    !> 'a, b' for messages.
    function vec_str(v) result(s)
        real(dp), intent(in) :: v(2)   !! vector
        character(len=:), allocatable :: s
        s = real_repr(v(1))//', '//real_repr(v(2))
    end function vec_str

    !> Integer as text.
    function int_str(i) result(s)
        integer, intent(in) :: i   !! value
        character(len=:), allocatable :: s
        character(len=16) :: buf
        write (buf, '(i0)') i
        s = trim(buf)
    end function int_str

    !> The shortest decimal that reads back as x, written like Python's repr(x)
    !> (decimal notation for 1e-4 <= |x| < 1e16, else d.ddde+XX).
    function real_repr(x) result(s)
        real(dp), intent(in) :: x   !! value
        character(len=:), allocatable :: s
        character(len=40) :: buf
        character(len=20) :: fmt
        character(len=:), allocatable :: digits, sgn, mant
        real(dp) :: y
        integer :: p, ios, ie, e, nd, i

        if (x /= x) then
            s = 'nan'
            return
        end if
        if (abs(x) > huge(x)) then
            s = merge('-inf', 'inf ', x < 0.0_dp)
            s = trim(s)
            return
        end if
        if (x == 0.0_dp) then
            s = merge('-0.0', '0.0 ', sign(1.0_dp, x) < 0.0_dp)
            s = trim(s)
            return
        end if
        do p = 1, 17
            write (fmt, '(a, i0, a)') '(es40.', p - 1, 'e4)'
            write (buf, fmt) x
            read (buf, *, iostat=ios) y
            if (ios == 0 .and. y == x) exit
        end do
        buf = adjustl(buf)
        sgn = ''
        if (buf(1:1) == '-') then
            sgn = '-'
            buf = buf(2:)
        end if
        ie = index(buf, 'E')
        mant = buf(1:ie - 1)
        read (buf(ie + 1:), *) e
        digits = ''
        do i = 1, len(mant)
            if (mant(i:i) /= '.') digits = digits//mant(i:i)
        end do
        nd = len(digits)
        do while (nd > 1 .and. digits(nd:nd) == '0')
            nd = nd - 1
        end do
        digits = digits(1:nd)
        if (e >= -4 .and. e < 16) then
            if (e >= 0) then
                if (nd > e + 1) then
                    s = sgn//digits(1:e + 1)//'.'//digits(e + 2:)
                else
                    s = sgn//digits//repeat('0', e + 1 - nd)//'.0'
                end if
            else
                s = sgn//'0.'//repeat('0', -e - 1)//digits
            end if
        else
            if (nd > 1) then
                s = sgn//digits(1:1)//'.'//digits(2:)
            else
                s = sgn//digits
            end if
            write (buf, '(i0.2)') abs(e)
            s = s//'e'//merge('-', '+', e < 0)//trim(buf)
        end if
    end function real_repr

    !> Raw tokens joined by ', ' (for messages).
    function joined(entry) result(s)
        type(entry_t), intent(in) :: entry   !! tokens
        character(len=:), allocatable :: s
        integer :: t
        s = ''
        do t = 1, entry%ntok
            if (t > 1) s = s//', '
            s = s//entry%tok(t)%raw
        end do
        s = sanitize(s, EXCERPT_LEN)
    end function joined

    !> The file text from position i to the end of its line, shortened for messages.
    function excerpt(text, i) result(s)
        character(len=*), intent(in) :: text   !! file contents
        integer, intent(in) :: i               !! start
        character(len=:), allocatable :: s
        integer :: j
        j = i
        do while (j <= len(text))
            if (text(j:j) == LF .or. text(j:j) == CR) exit
            j = j + 1
        end do
        s = sanitize(trim(text(i:j - 1)), EXCERPT_LEN)
    end function excerpt

    !> Printable ASCII only ('?' for other bytes), at most maxlen characters + '...'.
    pure function sanitize(s, maxlen) result(r)
        character(len=*), intent(in) :: s   !! text
        integer, intent(in) :: maxlen       !! longest kept
        character(len=:), allocatable :: r
        integer :: i, c
        r = s(1:min(len(s), maxlen))
        do i = 1, len(r)
            c = iachar(r(i:i))
            if (c < 32 .or. c > 126) r(i:i) = '?'
        end do
        if (len(s) > maxlen) r = r//'...'
    end function sanitize

    !> Lower-case ASCII copy.
    pure function lower(s) result(r)
        character(len=*), intent(in) :: s   !! text
        character(len=len(s)) :: r
        integer :: i, c
        r = s
        do i = 1, len(s)
            c = iachar(s(i:i))
            if (c >= 65 .and. c <= 90) r(i:i) = achar(c + 32)
        end do
    end function lower

    !> ASCII letter?
    pure logical function is_letter(c)
        character(len=1), intent(in) :: c   !! character
        is_letter = (c >= 'a' .and. c <= 'z') .or. (c >= 'A' .and. c <= 'Z')
    end function is_letter

    !> ASCII digit?
    pure logical function is_digit(c)
        character(len=1), intent(in) :: c   !! character
        is_digit = c >= '0' .and. c <= '9'
    end function is_digit

    !> Index of a group name (0 = unknown).
    pure integer function group_index(name)
        character(len=*), intent(in) :: name   !! lower-case name
        integer :: g
        group_index = 0
        do g = 1, N_GROUPS
            if (name == GROUP_NAMES(g)) group_index = g
        end do
    end function group_index

    !> Index of key `name` in group g (0 = unknown).
    pure integer function key_index(g, name)
        integer, intent(in) :: g               !! group index
        character(len=*), intent(in) :: name   !! lower-case key
        integer :: k
        key_index = 0
        if (len(name) > len(KEY_NAMES)) return
        do k = 1, N_KEYS
            if (KEY_GROUP(k) == g .and. name == KEY_NAMES(k)) key_index = k
        end do
    end function key_index

    !> '&mesh, &boundary, ...'
    function group_list() result(s)
        character(len=:), allocatable :: s
        integer :: g
        s = ''
        do g = 1, N_GROUPS
            if (g > 1) s = s//', '
            s = s//'&'//trim(GROUP_NAMES(g))
        end do
    end function group_list

    !> The keys of group g, comma-separated.
    function key_list(g) result(s)
        integer, intent(in) :: g   !! group index
        character(len=:), allocatable :: s
        integer :: k
        s = ''
        do k = 1, N_KEYS
            if (KEY_GROUP(k) /= g) cycle
            if (len(s) > 0) s = s//', '
            s = s//trim(KEY_NAMES(k))
        end do
    end function key_list
end module scene
