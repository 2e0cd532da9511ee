!> dyncontact executable: `dyncontact SCENE.nml [--out DIR]`. The only place that stops.
program main
    use simulation, only: simulation_t, sim_open, sim_advance, sim_close
    use iso_c_binding, only: c_int
    use errors, only: STAT_OK, MSG_LEN
    implicit none
    interface
        !> C exit(): ends the program with a status and no extra output.
        subroutine c_exit(status) bind(C, name='exit')
            import :: c_int
            integer(c_int), value :: status
        end subroutine c_exit
    end interface
    type(simulation_t) :: sim
    character(len=1024) :: scene_path, out_dir, arg
    character(len=MSG_LEN) :: errmsg
    integer :: stat, nargs, i, done
    scene_path = ''; out_dir = ''; errmsg = ''
    nargs = command_argument_count()
    i = 1
    do while (i <= nargs)
        call get_command_argument(i, arg)
        if (arg == '--out') then
            i = i + 1
            call get_command_argument(i, out_dir)
        else
            scene_path = arg
        end if
        i = i + 1
    end do
    if (len_trim(scene_path) == 0) then
        write (0, '(a)') 'usage: dyncontact SCENE.nml [--out DIR]'
        call c_exit(2_c_int)
    end if
    call sim_open(sim, scene_path, out_dir, .true., stat, errmsg)
    if (stat /= STAT_OK) call fail(stat, errmsg)
    write (*, '(a, i0, a, i0, a, i0, a, i0, a)') 'dyncontact: '//trim(scene_path)//': ', &
        sim%n_dofs, ' dofs, ', sim%n_cells, ' elements, ', sim%n_contact, &
        ' contact facets; '//trim(sim%scn%scheme_name)//', ', sim%n_steps, &
        ' steps -> '//trim(sim%scn%out_dir)
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
    write (*, '(a, i0, a, g0.6, a)') 'dyncontact: ok, ', sim%step, ' steps to t=', sim%st%t, &
        ' -> '//trim(sim%scn%out_dir)

contains

    !> Print the one-line message and exit with the status of the code (2, 3 or 4).
    subroutine fail(code, msg)
        integer, intent(in) :: code            !! STAT_* code
        character(len=*), intent(in) :: msg   !! message
        write (0, '(a)') 'dyncontact: '//trim(msg)
        select case (code)
        case (2, 3); call c_exit(int(code, c_int))
        case default; call c_exit(4_c_int)
        end select
    end subroutine fail
end program main
