!> Unit tests of the stop flag (module stop_signal) in a run's set-up: before any signal
!> the set-up's pieces succeed; once the executable's handler has caught SIGINT
!> (signals_install, then a SIGINT raised at the process itself) check_stop, the
!> assembly (model_build), the ordering of a node-block matrix (chol_analyse) and a
!> factorization (chol_factor) return STAT_INTERRUPTED instead of doing their work, and
!> the flag holds the signal's number. Exit status 1 (error stop) on any failure.
program test_stop_signal
    use iso_c_binding, only: c_int, c_long
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_INTERRUPTED, MSG_LEN
    use stop_signal, only: signal_caught, check_stop
    use os_files, only: signals_install
    use mesh, only: mesh_t
    use bar_mesh, only: bar_mesh_build
    use cholmod, only: cholmod_t, chol_factor, chol_analyse, chol_free
    use model, only: model_t, model_params_t, model_build, MASS_CONSISTENT
    use unit_checks, only: checks_t
    implicit none
    interface
        !> C raise(): the signal sent to the calling thread, handled before it returns.
        function c_raise(sig) bind(C, name='raise') result(r)
            import :: c_int
            integer(c_int), value :: sig    !! signal number
            integer(c_int) :: r
        end function c_raise
    end interface
    integer(c_int), parameter :: SIGINT = 2
    type(checks_t) :: checks
    type(mesh_t) :: msh
    type(model_params_t) :: prm
    type(model_t) :: mdl
    type(cholmod_t) :: ch
    character(len=MSG_LEN) :: msg
    integer(c_long) :: entries
    integer :: stat

    call bar_mesh_build(3, 1.0_dp, 0.1_dp, 0.05_dp, msh, stat, msg)
    call checks%check(stat == STAT_OK, 'the built-in 3D bar: '//trim(msg))
    prm%clamped = 'top'; prm%contact = 'bottom'
    prm%young = 2.0_dp / 3.0_dp; prm%poisson = 1.0_dp / 3.0_dp
    prm%obstacle_normal = [0.0_dp, 0.0_dp, -1.0_dp]
    prm%probe = [0.05_dp, 0.05_dp, 0.0_dp]
    prm%mass = MASS_CONSISTENT

    ! no signal yet: every piece does its work
    call checks%check(signal_caught() == 0, 'no signal caught at the start')
    stat = STAT_OK
    call check_stop('the test', stat, msg)
    call checks%check(stat == STAT_OK, 'check_stop without a signal')
    call model_build(msh, prm, mdl, stat, msg)
    call checks%check(stat == STAT_OK, 'model_build without a signal: '//trim(msg))
    call chol_factor(ch, mdl%stiff, stat, msg)
    call checks%check(stat == STAT_OK, 'chol_factor without a signal: '//trim(msg))
    call chol_free(ch)

    ! Ctrl-C caught by the executable's handler
    call signals_install(stat, msg)
    call checks%check(stat == STAT_OK, 'signals_install: '//trim(msg))
    call checks%check(c_raise(SIGINT) == 0, 'raise(SIGINT)')
    call checks%check(signal_caught() == SIGINT, 'the flag holds SIGINT')

    stat = STAT_OK
    call check_stop('the test', stat, msg)
    call checks%check(stat == STAT_INTERRUPTED, 'check_stop after the signal')
    call checks%check(trim(msg) == 'interrupted by signal 2 during the test', &
                      'check_stop''s message: '//trim(msg))
    call model_build(msh, prm, mdl, stat, msg)
    call checks%check(stat == STAT_INTERRUPTED, 'model_build after the signal: '//trim(msg))
    call checks%check(trim(msg) == 'interrupted by signal 2 during the assembly', &
                      'model_build''s message: '//trim(msg))
    ! a fresh analysis of the pattern the interrupted build made (3x3 node blocks)
    call chol_analyse(ch, mdl%stiff, entries, stat, msg)
    call checks%check(stat == STAT_INTERRUPTED, 'chol_analyse (orderings) after the '// &
                      'signal: '//trim(msg))
    call chol_free(ch)
    call chol_factor(ch, mdl%stiff, stat, msg)
    call checks%check(stat == STAT_INTERRUPTED, 'chol_factor after the signal: '//trim(msg))
    call chol_free(ch)
    call checks%check(signal_caught() == SIGINT, 'the flag still holds SIGINT')

    call checks%finish('test_stop_signal')
end program test_stop_signal
