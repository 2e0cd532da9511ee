!> dyncontact executable: `dyncontact SCENE.nml [--out DIR] [--restart DIR]` (or
!> --out=DIR, --restart=DIR). The only place that stops.
program main
    use simulation, only: simulation_t, sim_open, sim_advance, sim_close
    use iso_c_binding, only: c_int
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_INTERRUPTED, MSG_LEN
    use scene, only: PATH_LEN
    use os_files, only: signals_install
    use version_info, only: DYNCONTACT_VERSION
    use text, only: int_text, real_text, counted
    use run_lines, only: start_line, restart_line
    use run_help_text, only: print_run_help
    implicit none
    interface
        !> C exit(): ends the program with a status and no extra output.
        subroutine c_exit(status) bind(C, name='exit')
            import :: c_int
            integer(c_int), value :: status  !! exit status
        end subroutine c_exit
    end interface
    character(len=*), parameter :: USAGE = &
        'usage: dyncontact SCENE.nml [--out DIR] [--restart DIR] | --help | --version'
    type(simulation_t) :: sim
    character(len=PATH_LEN) :: scene_path, out_dir, restart_dir
    character(len=:), allocatable :: arg
    character(len=MSG_LEN) :: errmsg
    integer :: stat, nargs, i, done
    scene_path = ''; out_dir = ''; restart_dir = ''; errmsg = ''
    nargs = command_argument_count()
    i = 1
    do while (i <= nargs)
        arg = argument(i)
        select case (arg)
        case ('--help', '-h')
            write (*, '(a)') USAGE
            write (*, '(a)') 'Runs a scene file and writes trace.csv and summary.json into the output folder'
            write (*, '(a)') '(&output dir, or DIR). With the Python package installed, `python -m dyncontact'
            write (*, '(a)') 'run --help` gives the Python command line, which also takes --set GROUP.KEY=VALUE,'
            write (*, '(a)') '--quiet and --wait.'
            write (*, '(a)') '--out DIR and --restart DIR may be written --out=DIR and --restart=DIR.'
            write (*, '(a)') '--restart DIR continues a stopped run from DIR/checkpoint.bin (written with'
            write (*, '(a)') '&output checkpoint_every > 0), appending to DIR/trace.csv; a later'
            write (*, '(a)') '&scheme t_end or a raised blowup in SCENE.nml extends the run.'
            ! the scene files and exit statuses, from python/dyncontact/run_help.txt, which
            ! `python -m dyncontact run --help` prints too (meson.build generates the module)
            call print_run_help()
            call c_exit(0_c_int)
        case ('--version', '-V')
            write (*, '(a)') 'dyncontact '//DYNCONTACT_VERSION
            call c_exit(0_c_int)
        case ('--out')
            call folder_argument('--out', i, out_dir)
        case ('--restart')
            call folder_argument('--restart', i, restart_dir)
        case default
            ! --out=DIR and --restart=DIR, as `python -m dyncontact run` (argparse) takes them
            if (starts_with(arg, '--out=')) then
                call folder_given('--out', arg(len('--out=') + 1:), out_dir)
                i = i + 1
                cycle
            else if (starts_with(arg, '--restart=')) then
                call folder_given('--restart', arg(len('--restart=') + 1:), restart_dir)
                i = i + 1
                cycle
            end if
            if (len(arg) > 1) then
                if (arg(1:1) == '-') then
                    if (len(python_run_option(arg)) > 0) call fail(STAT_BAD_INPUT, &
                        python_run_option(arg)//' belongs to `python -m dyncontact run`, '// &
                        'not to the executable ('//USAGE//')')
                    call fail(STAT_BAD_INPUT, 'unknown option '//arg//' ('//USAGE//')')
                end if
            end if
            ! `dyncontact run s.nml`, `dyncontact mesh ...`: the Python command line's
            ! words, said as such rather than as a missing scene file named 'run'
            if (len_trim(scene_path) == 0 .and. is_python_command(arg)) call fail(STAT_BAD_INPUT, &
                "'"//arg//"' is a command of `python -m dyncontact`, not of the executable, "// &
                'which takes the scene file alone ('//USAGE//')')
            if (len_trim(scene_path) > 0) call fail(STAT_BAD_INPUT, 'two scene files given ('// &
                                                    trim(scene_path)//', '//arg//'); '//USAGE)
            scene_path = arg
        end select
        i = i + 1
    end do
    ! (the program's variables live on its stack: what is still allocated when it returns
    ! is, to a leak checker, memory lost)
    if (allocated(arg)) deallocate (arg)
    if (len_trim(scene_path) == 0) then
        write (0, '(a)') USAGE
        call c_exit(2_c_int)
    end if
    call signals_install(stat, errmsg)
    if (stat /= STAT_OK) call fail(stat, errmsg)
    if (len_trim(out_dir) > 0) then     ! an output folder that cannot be made is named as given
        call sim_open(sim, scene_path, out_dir, .true., stat, errmsg, restart=restart_dir, &
                      out_said='--out '//trim(out_dir))
    else
        call sim_open(sim, scene_path, out_dir, .true., stat, errmsg, restart=restart_dir)
    end if
    if (stat /= STAT_OK) call fail(stat, errmsg)
    if (sim%restart_step >= 0) write (*, '(a)') 'dyncontact: '//restart_line(sim)
    write (*, '(a)') 'dyncontact: '//start_line(sim, trim(scene_path), trim(sim%scn%out_dir))
    call print_warnings(sim%mdl%notes)
    flush (6)
    do while (.not. sim%finished)
        call sim_advance(sim, 1000, done, stat, errmsg)
        if (stat /= STAT_OK) exit
    end do
    block
        integer :: stat2
        character(len=MSG_LEN) :: msg2
        call sim_close(sim, stat2, msg2)
        if (stat == STAT_OK .and. stat2 /= STAT_OK) then
            stat = stat2
            errmsg = msg2
        end if
    end block
    if (stat /= STAT_OK) call fail(stat, errmsg)
    write (*, '(a)') 'dyncontact: ok, '//counted(sim%step, 'step')//' to t='// &
        real_text(sim%st%t, 6)//' -> '//trim(sim%scn%out_dir)

contains

    !> Command argument i, whole (an argument longer than the path limit is an error).
    function argument(k) result(a)
        integer, intent(in) :: k    !! argument number
        character(len=:), allocatable :: a
        integer :: n, st
        call get_command_argument(k, length=n, status=st)
        if (n > PATH_LEN .or. st > 0) then
            call fail(STAT_BAD_INPUT, 'argument '//int_text(k)//' is longer than the limit of ' &
                      //int_text(PATH_LEN)//' characters')
        end if
        allocate (character(len=n) :: a)
        if (n > 0) call get_command_argument(k, a)
    end function argument

    !> The folder named after `option` (argument k): k moves on to it. A missing or empty
    !> folder name, or the option given twice, stops the program.
    subroutine folder_argument(option, k, dir)
        character(len=*), intent(in) :: option   !! '--out' or '--restart'
        integer, intent(inout) :: k              !! the option's argument number, then the folder's
        character(len=*), intent(inout) :: dir   !! the folder ('' until given)
        character(len=:), allocatable :: a
        if (k == nargs) call fail(STAT_BAD_INPUT, option//' needs a folder ('//USAGE//')')
        k = k + 1
        a = argument(k)
        call folder_given(option, a, dir)
    end subroutine folder_argument

    !> The folder `a` given to `option` (after it, or after its '='). An empty folder
    !> name, or the option given twice, stops the program.
    subroutine folder_given(option, a, dir)
        character(len=*), intent(in) :: option   !! '--out' or '--restart'
        character(len=*), intent(in) :: a        !! the folder as given
        character(len=*), intent(inout) :: dir   !! the folder ('' until given)
        if (len(a) == 0) call fail(STAT_BAD_INPUT, option//': empty folder name')
        if (len_trim(dir) > 0) call fail(STAT_BAD_INPUT, option//' given twice ('//trim(dir)// &
                                         ', '//a//'); '//USAGE)
        dir = a
    end subroutine folder_given

    !> Whether `a` begins with `prefix`.
    pure logical function starts_with(a, prefix)
        character(len=*), intent(in) :: a        !! a command argument
        character(len=*), intent(in) :: prefix   !! its possible beginning
        starts_with = .false.
        if (len(a) >= len(prefix)) starts_with = a(1:len(prefix)) == prefix
    end function starts_with

    !> Whether `a` is a command of `python -m dyncontact` (run, plot, mesh, study) and no
    !> file of that name is there to be a scene file.
    logical function is_python_command(a)
        character(len=*), intent(in) :: a   !! the first argument that is not an option
        logical :: exists
        is_python_command = .false.
        select case (a)
        case ('run', 'plot', 'mesh', 'study')
            inquire (file=a, exist=exists)
            is_python_command = .not. exists
        end select
    end function is_python_command

    !> The option of `python -m dyncontact run` that the executable does not take which
    !> `a` is (its name, before any '=': `--set=scheme.dt=0.001` is --set), or ''.
    function python_run_option(a) result(name)
        character(len=*), intent(in) :: a   !! a command argument
        character(len=:), allocatable :: name
        integer :: eq
        eq = index(a, '=')
        if (eq > 0) then
            name = a(1:eq - 1)
        else
            name = a
        end if
        select case (name)
        case ('--set', '--wait', '--quiet', '-q')
        case default
            name = ''
        end select
    end function python_run_option

    !> Print the model's warnings and notes, one line each, on stderr.
    subroutine print_warnings(notes)
        character(len=*), intent(in) :: notes   !! lines separated by new_line
        integer :: a, b
        a = 1
        do while (a <= len_trim(notes))
            b = index(notes(a:), new_line('a'))
            if (b == 0) then
                b = len_trim(notes) + 1
            else
                b = a + b - 1
            end if
            if (b > a) write (0, '(a)') 'dyncontact: '//notes(a:b - 1)
            a = b + 1
        end do
    end subroutine print_warnings

    !> Print the one-line message and exit with the status of the code (2, 3, 4 or 130).
    subroutine fail(code, msg)
        integer, intent(in) :: code            !! STAT_* code
        character(len=*), intent(in) :: msg   !! message
        write (0, '(a)') 'dyncontact: '//trim(msg)
        select case (code)
        case (2, 3); call c_exit(int(code, c_int))
        case (STAT_INTERRUPTED); call c_exit(130_c_int)
        case default; call c_exit(4_c_int)
        end select
    end subroutine fail
end program main
