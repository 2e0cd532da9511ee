!> contact_clear, the test of a step in flight, against what it stands for: on random
!> 3D (triangle facets) and 2D (segment facets) contact data, with the gaps drawn so that
!> some draws have P >= 0 at every facet's node and others not, clear is true exactly when
!> contact_eval finds P finite and >= 0 at all nodes (checked node by node here); when it
!> is, contact_eval adds nothing to r (bit for bit), returns active = 0, e_pen = 0, rank 0
!> and rg = 0 and the same e_theta (bit for bit), and facet_pressure at each facet node
!> (shape values e_k, the probe at a node) is 0. A NaN or an infinity in u is never clear.
!> Exit status 1 (error stop) on any failure.
program test_contact_clear
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_positive_inf, ieee_quiet_nan
    use, intrinsic :: ieee_exceptions, only: ieee_get_halting_mode, ieee_set_halting_mode, &
                                             ieee_usual
    use kinds, only: dp
    use nitsche_contact, only: contact_t, contact_eval, contact_clear, facet_pressure, MAX_FN
    use unit_checks, only: checks_t, seed
    implicit none
    integer, parameter :: NFAC = 6, NU = 40
    type(checks_t) :: checks
    type(contact_t) :: ct
    real(dp) :: u(NU), r(NU), r0(NU), e_pen, e_theta, et, nsh(MAX_FN), p, sn, un
    real(dp) :: ua(12, 6 * NFAC), vb(12, 6 * NFAC), tca(3, 6 * NFAC), tcb(3, 6 * NFAC)
    real(dp) :: rg(3, NFAC)
    integer :: qloc(12, 6 * NFAC), tfac(6 * NFAC)
    integer :: dim, trial, active, rank, f, j, n_clear, n_not
    logical :: clear, all_ok, halting(3)

    call seed(4217)
    do dim = 2, 3
        call random_contact(dim)
        n_clear = 0
        n_not = 0
        do trial = 1, 200
            call random_number(u)
            u = 0.02_dp * (u - 0.5_dp)
            call random_number(ct%gap)
            ! every other draw wider open: some draws clear, others not
            ct%gap = 0.03_dp * (ct%gap - 0.1_dp) + 0.02_dp * mod(trial, 2)
            call contact_clear(ct, u, clear, et)
            ! P at every node, as contact_eval forms it (sigma_n(u), then u_n - g)
            all_ok = .true.
            do f = 1, ct%n_facets
                sn = dot_product(ct%s(:, f), u(ct%dofs(:, f)))
                do j = 1, ct%nfn
                    un = dot_product(u(ct%dofs(:, f)), ct%nvec(:, j, f)) - ct%gap(j, f)
                    if (.not. sn - ct%gamma(f) * un >= 0.0_dp) all_ok = .false.
                end do
            end do
            call checks%check(clear .eqv. all_ok, 'clear iff P >= 0 at every facet node')
            if (.not. clear) then
                n_not = n_not + 1
                cycle
            end if
            n_clear = n_clear + 1
            call random_number(r0)
            r = r0
            rg = 1.0_dp
            call contact_eval(ct, u, r, active, e_pen, e_theta, rank, ua, vb, qloc, tfac, tca, &
                              tcb, rg)
            call checks%check(all(r == r0) .and. active == 0 .and. e_pen == 0.0_dp .and. &
                              rank == 0 .and. all(rg(1:ct%nfn, :) == 0.0_dp), &
                              'clear: contact_eval adds nothing, no term, rg = 0')
            call checks%check(e_theta == et, 'clear: the same e_theta, bit for bit')
            do f = 1, ct%n_facets
                do j = 1, ct%nfn
                    nsh = 0.0_dp
                    nsh(j) = 1.0_dp
                    p = facet_pressure(ct%ndof_e, ct%nfn, u(ct%dofs(:, f)), ct%s(:, f), &
                                       ct%nvec(:, :, f), ct%gap(:, f), ct%gamma(f), nsh)
                    call checks%check(p == 0.0_dp, 'clear: [P]_- = 0 at every facet node')
                end do
            end do
        end do
        ! both outcomes drawn, else the checks above prove little
        print "(a, i0, a, i0, a, i0)", "dimension ", dim, ": clear ", n_clear, ", not ", n_not
        call checks%check(n_clear > 10 .and. n_not > 10, 'draws with and without contact')
        ! not finite: never clear
        ct%gap = 1.0_dp
        u = 0.0_dp
        call contact_clear(ct, u, clear, et)
        call checks%check(clear, 'at rest, open gaps: clear')
        ! an infinity or a NaN in u: the sums then compute with them (inf * 0 is NaN), as
        ! meant, so not trapped where the build traps them (scripts/checked)
        call ieee_get_halting_mode(ieee_usual, halting)
        call ieee_set_halting_mode(ieee_usual, .false.)
        u(ct%dofs(1, 1)) = ieee_value(1.0_dp, ieee_positive_inf)
        call contact_clear(ct, u, clear, et)
        call checks%check(.not. clear, 'an infinity in u: not clear')
        u(ct%dofs(1, 1)) = ieee_value(1.0_dp, ieee_quiet_nan)
        call contact_clear(ct, u, clear, et)
        call checks%check(.not. clear, 'a NaN in u: not clear')
        call ieee_set_halting_mode(ieee_usual, halting)
    end do
    call checks%finish('test_contact_clear')

contains

    !> Random contact data of NFAC facets in dimension d: owner cells of d (d + 1) dofs
    !> drawn among NU free dofs, sigma_n rows, normal rows, gamma_N; exact quadrature.
    subroutine random_contact(d)
        integer, intent(in) :: d     !! dimension (2 or 3)
        real(dp) :: x(NU)
        integer :: ff, i
        ct%dim = d
        ct%n_facets = NFAC
        ct%ndof_e = d * (d + 1)
        ct%nfn = d
        ct%theta = 1
        if (allocated(ct%dofs)) deallocate (ct%dofs, ct%s, ct%nvec, ct%gap, ct%gamma, &
                                            ct%measure, ct%cloc)
        allocate (ct%dofs(ct%ndof_e, NFAC), ct%s(ct%ndof_e, NFAC), &
                  ct%nvec(ct%ndof_e, d, NFAC), ct%gap(d, NFAC), ct%gamma(NFAC), &
                  ct%measure(NFAC), ct%cloc(ct%ndof_e, NFAC))
        do ff = 1, NFAC
            call random_number(x)
            do i = 1, ct%ndof_e       ! distinct dofs: the ndof_e smallest draws' places
                ct%dofs(i, ff) = minloc(x, dim=1)
                x(ct%dofs(i, ff)) = 2.0_dp
            end do
            ct%cloc(:, ff) = ct%dofs(:, ff)
        end do
        call random_number(ct%s)
        ct%s = 0.1_dp * (ct%s - 0.5_dp)
        call random_number(ct%nvec)
        ct%nvec = ct%nvec - 0.5_dp
        call random_number(ct%gamma)
        ct%gamma = 1.0_dp + ct%gamma
        call random_number(ct%measure)
    end subroutine random_contact

end program test_contact_clear
