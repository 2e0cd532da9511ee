!> Rotation invariance in 3D: the box (built-in, h = 0.05), the obstacle, the probe and the
!> initial state (compressed bar) turned by an arbitrary rotation R give the same probe
!> trace (u_n, v_n, p_n) and the rotated displacement field, step by step, to 1e-12 of the
!> size of what each is computed from (HHT alpha = 0 through the first impact; both
!> contact quadratures, Nitsche theta = 1, the three masses). Exit status 1 (error stop) on any failure.
program test_rotation3d
    use kinds, only: dp
    use errors, only: STAT_OK
    use mesh, only: mesh_t
    use bar_mesh, only: bar_mesh_build
    use model, only: model_t, model_params_t, model_build, model_initial, model_probe, &
                     model_mass_apply, INITIAL_COMPRESSED_BAR, MASS_CONSISTENT, MASS_LUMPED, &
                     MASS_REDISTRIBUTED
    use nitsche_contact, only: QUAD_EXACT, QUAD_GAUSS
    use time_scheme, only: state_t, state_eval, scheme_params_t, SCHEME_HHT
    use implicit_schemes, only: implicit_scheme_t
    use unit_checks, only: checks_t
    implicit none
    type(checks_t) :: checks
    real(dp), parameter :: TOL = 1.0e-12_dp
    real(dp) :: r(3, 3)
    integer :: quad, mass

    r = rotation(0.7_dp, -1.1_dp, 2.3_dp)
    call checks%check(maxval(abs(matmul(transpose(r), r) - identity())) < 1.0e-15_dp, 'R orthogonal')
    do quad = QUAD_EXACT, QUAD_GAUSS
        do mass = MASS_CONSISTENT, MASS_REDISTRIBUTED
            call compare(quad, mass)
        end do
    end do
    call checks%finish('test_rotation3d')

contains

    !> Run the box and the rotated box side by side, comparing every step.
    subroutine compare(quad, mass)
        integer, intent(in) :: quad, mass
        integer, parameter :: STEPS = 600     ! t = 1.5: past the first impact (t ~ 1.21)
        type(mesh_t) :: msh, mrot
        type(model_params_t) :: prm, prot
        type(model_t) :: m1, m2
        type(state_t) :: s1, s2
        type(scheme_params_t) :: sp
        type(implicit_scheme_t) :: h1, h2
        integer :: stat, k, i, n
        real(dp) :: p1(3), p2(3), du, umax, dq(3), qmax(3), scale(3)
        character(len=300) :: msg
        character(len=40) :: what
        write (what, '(a, i0, a, i0)') 'quadrature ', quad, ', mass ', mass
        call bar_mesh_build(3, 1.0_dp, 0.1_dp, 0.05_dp, msh, stat, msg)
        mrot = msh
        mrot%x = matmul(r, msh%x)
        prm%clamped = 'top'; prm%contact = 'bottom'
        prm%young = 2.0_dp / 3.0_dp; prm%poisson = 1.0_dp / 3.0_dp
        prm%obstacle_normal = [0.0_dp, 0.0_dp, -1.0_dp]
        prm%obstacle_point = [0.0_dp, 0.0_dp, 0.0_dp]
        prm%probe = [0.05_dp, 0.05_dp, 0.0_dp]
        prm%initial = INITIAL_COMPRESSED_BAR; prm%amplitude = 0.5_dp; prm%length = 1.0_dp
        prm%quadrature = quad; prm%quad_points = 7; prm%mass = mass
        if (mass == MASS_REDISTRIBUTED) prm%gamma0 = 20.0_dp
        prot = prm
        prot%obstacle_normal = matmul(r, prm%obstacle_normal)
        prot%obstacle_point = matmul(r, [0.3_dp, -0.2_dp, 0.0_dp])   ! another point of the plane
        prm%obstacle_point = [0.3_dp, -0.2_dp, 0.0_dp]
        prot%probe = matmul(r, prm%probe)
        call model_build(msh, prm, m1, stat, msg)
        call checks%check(stat == STAT_OK, 'model builds: '//trim(msg))
        call model_build(mrot, prot, m2, stat, msg)
        call checks%check(stat == STAT_OK, 'rotated model builds: '//trim(msg))
        if (stat /= STAT_OK) return
        n = m1%n_dofs
        call checks%check(m2%n_dofs == n .and. m1%n_probe == m2%n_probe, 'same dofs and probe facets')
        sp%kind = SCHEME_HHT; sp%dt = 0.0025_dp; sp%t_end = STEPS * sp%dt; sp%alpha = 0.0_dp
        call start(m1, prm, s1)
        call start(m2, prot, s2)
        call h1%init(m1, sp, s1, stat, msg)
        call h2%init(m2, sp, s2, stat, msg)
        umax = 0.0_dp; qmax = 0.0_dp
        du = 0.0_dp; dq = 0.0_dp
        do k = 1, STEPS
            call h1%step(m1, s1, stat, msg)
            call h2%step(m2, s2, stat, msg)
            call model_probe(m1, s1%u, s1%v, p1(1), p1(2), p1(3))
            call model_probe(m2, s2%u, s2%v, p2(1), p2(2), p2(3))
            dq = max(dq, abs(p1 - p2))
            qmax = max(qmax, abs(p1))
            do i = 1, n, 3     ! node-major dofs: the node's three components
                du = max(du, maxval(abs(matmul(r, s1%u(i:i + 2)) - s2%u(i:i + 2))))
            end do
            umax = max(umax, maxval(abs(s1%u)))
        end do
        call checks%check(all(qmax > 0.1_dp), 'the probe moves and is pressed: '//trim(what))
        ! each probe value against the size of what it is computed from: u_n the
        ! displacement; v_n the trapezoidal 2 (u' - u) / dt - v, so displacement round-off
        ! enters as |u| / dt; p_n = sigma_n - gamma_N (u_n - g), terms of size gamma_N |u|
        scale = [umax, umax / sp%dt, maxval(m1%ct%gamma) * umax]
        call checks%check(all(dq <= TOL * scale), 'probe trace rotation invariant: '//trim(what))
        call checks%check(du <= TOL * umax, 'displacement field rotates: '//trim(what))
        print '(a, a, 3es9.2, a, es9.2)', trim(what), ': probe u_n, v_n, p_n max diff / scale ', &
            dq / scale, ', field ', du / umax
        call h1%free()
        call h2%free()
    end subroutine compare

    !> Initial state as the run sets it up.
    subroutine start(mdl, prm, st)
        type(model_t), intent(in) :: mdl
        type(model_params_t), intent(in) :: prm
        type(state_t), intent(inout) :: st
        integer :: n
        n = mdl%n_dofs
        allocate (st%u(n), st%v(n), st%a(n), st%bu(n), st%ktu(n), st%mv(n))
        call model_initial(mdl, prm, st%u, st%v)
        call state_eval(mdl, st)
        call model_mass_apply(mdl, st%v, st%mv)
        st%a = 0.0_dp
    end subroutine start

    !> R = Rz(c) Ry(b) Rx(a).
    pure function rotation(a, b, c) result(r)
        real(dp), intent(in) :: a, b, c
        real(dp) :: r(3, 3), rx(3, 3), ry(3, 3), rz(3, 3)
        rx = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, cos(a), sin(a), 0.0_dp, -sin(a), cos(a)], [3, 3])
        ry = reshape([cos(b), 0.0_dp, -sin(b), 0.0_dp, 1.0_dp, 0.0_dp, sin(b), 0.0_dp, cos(b)], [3, 3])
        rz = reshape([cos(c), sin(c), 0.0_dp, -sin(c), cos(c), 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], [3, 3])
        r = matmul(rz, matmul(ry, rx))
    end function rotation

    pure function identity() result(e)
        real(dp) :: e(3, 3)
        integer :: i
        e = 0.0_dp
        do i = 1, 3
            e(i, i) = 1.0_dp
        end do
    end function identity
end program test_rotation3d
