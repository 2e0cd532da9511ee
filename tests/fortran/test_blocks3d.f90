!> The 3x3 node-block kernels on a 3D box model (built-in box, h = 0.05, top clamped,
!> contact at the bottom): the products by node blocks (block3_t) against the CSC products
!> they stand for, bit for bit, with every node free (triples: the scalar-block mass, the
!> fused passes) and with some nodes' z fixed (groups of two and three dofs: the general
!> path); the triangular solves by node triples (triple_ldl_t) against cholmod_solve2 on
!> the same factor, to round-off, one and many right-hand sides; the scalar mass solver
!> with three right-hand sides against M. Exit status 1 (error stop) on any failure.
program test_blocks3d
    use kinds, only: dp
    use errors, only: STAT_OK
    use mesh, only: mesh_t
    use bar_mesh, only: bar_mesh_build
    use sparse, only: csc_t, csc_matvec, csc_matvec_t, csc_matvec_t_values, block3_matvec, &
                      block3_matvec_km, block3_matvec_ks2, block3_matvec_ks3
    use cholmod, only: cholmod_t, chol_factor, chol_solve, chol_solve_many, chol_solve_cholmod, &
                       chol_kernel, chol_free, KERNEL_TRIPLES, KERNEL_CHOLMOD
    use ldl_solves, only: triple_ldl_t, triple_ldl_build
    use model, only: model_t, model_params_t, model_build, model_stiff_apply, model_step_products, &
                     model_stiff_mass_apply, model_mass_apply, model_stiff_theta_values, &
                     MASS_CONSISTENT
    use mass_solver, only: mass_solver_t, mass_solver_init, mass_solver_apply, mass_solver_free
    use unit_checks, only: checks_t, seed
    implicit none
    type(checks_t) :: checks

    call seed(2024)
    call test_box('every node free', '', .true.)
    call test_box('z fixed on the sides', 'sides', .false.)
    call test_triple_structure()
    call checks%finish('test_blocks3d')

contains

    !> The box model's products and solves; slip_z: groups with u_z = 0; triples: every
    !> free node has three dofs.
    subroutine test_box(what, slip_z, triples)
        character(len=*), intent(in) :: what           !! case name
        character(len=*), intent(in) :: slip_z         !! &boundary slip_z
        logical, intent(in) :: triples                 !! expected: every group a triple
        type(mesh_t) :: msh
        type(model_params_t) :: prm
        type(model_t) :: mdl
        integer :: stat, n
        character(len=300) :: msg
        real(dp), allocatable :: x(:), v(:), d(:), kx(:), mv(:), md(:), bx(:), &
                                 kx0(:), mv0(:), md0(:), y(:)
        type(csc_t) :: kth, mm
        call bar_mesh_build(3, 1.0_dp, 0.1_dp, 0.05_dp, msh, stat, msg)
        call checks%check(stat == STAT_OK, what//': box builds')
        prm%clamped = 'top'; prm%contact = 'bottom'; prm%slip_z = slip_z
        prm%young = 2.0_dp / 3.0_dp; prm%poisson = 1.0_dp / 3.0_dp
        prm%obstacle_normal = [0.0_dp, 0.0_dp, -1.0_dp]
        prm%probe = [0.05_dp, 0.05_dp, 0.0_dp]
        prm%mass = MASS_CONSISTENT
        call model_build(msh, prm, mdl, stat, msg)
        call checks%check(stat == STAT_OK, what//': model builds: '//trim(msg))
        if (stat /= STAT_OK) return
        n = mdl%n_dofs
        call checks%check(mdl%blocked, what//': K_theta and M copied by node blocks')
        call checks%check(mdl%stiff_theta_b3%triples .eqv. triples, what//': triples flag')
        call checks%check(mdl%mass_scalar .eqv. triples, what//': scalar mass blocks iff triples')
        call checks%check(mdl%stiff_theta_b3%n_groups < n, what//': nodes grouped')
        allocate (x(n), v(n), d(n), kx(n), mv(n), md(n), bx(n), kx0(n), mv0(n), md0(n), y(n))
        call random_number(x)
        call random_number(v)
        call random_number(d)
        x = x - 0.5_dp
        v = v - 0.5_dp
        ! M and K_theta are values on K's pattern: each as a matrix of its own (pattern
        ! copied), the products on the shared pattern are bitwise theirs
        call checks%check(size(mdl%mass_val) == mdl%stiff%nnz .and. &
                          .not. allocated(mdl%stiff_theta_val), &
                          what//': M on the one pattern of K, K_theta in its blocks only')
        kth = mdl%stiff
        call model_stiff_theta_values(mdl, kth%val)
        mm = mdl%stiff
        mm%val = mdl%mass_val
        call csc_matvec_t(kth, x, kx0)
        call csc_matvec_t(mm, v, mv0)
        call csc_matvec_t(mm, d, md0)
        call csc_matvec_t_values(mdl%stiff, kth%val, x, kx)
        call csc_matvec_t_values(mdl%stiff, mdl%mass_val, v, mv)
        call csc_matvec_t_values(mdl%stiff, mdl%mass_val, d, md)
        call checks%check(all(kx == kx0) .and. all(mv == mv0) .and. all(md == md0), &
                          what//': products on the shared pattern bitwise = own-pattern CSC')
        ! K x by blocks: bitwise the gather-form CSC product, to 1e-15 the scatter form
        call block3_matvec(mdl%stiff_theta_b3, x, kx)
        call checks%check(all(kx == kx0), what//': block3 K x bitwise = CSC')
        call csc_matvec(kth, x, y)
        call checks%check(maxval(abs(kx - y)) <= 1.0e-15_dp * maxval(abs(y)), &
                          what//': block3 K x = scattered CSC product')
        call model_stiff_apply(mdl, x, kx)
        call checks%check(all(kx == kx0), what//': model_stiff_apply bitwise = CSC')
        if (mdl%mass_scalar) then
            ! M's blocks are mass_s I on K_theta's block pattern: no block copy of M
            call checks%check(.not. allocated(mdl%mass_b3%val) .and. &
                              size(mdl%mass_s) == size(mdl%stiff_theta_b3%col1), &
                              what//': M''s block copy dropped, its scalars kept')
        else
            call block3_matvec(mdl%mass_b3, v, mv)
            call checks%check(all(mv == mv0), what//': block3 M v bitwise = CSC')
            call block3_matvec_km(mdl%stiff_theta_b3, mdl%mass_b3, x, v, d, kx, mv, md)
            call checks%check(all(kx == kx0) .and. all(mv == mv0) .and. all(md == md0), &
                              what//': block3 fused K x, M v, M d bitwise = CSC')
        end if
        call model_mass_apply(mdl, v, mv)
        call checks%check(all(mv == mv0), what//': model_mass_apply bitwise = CSC')
        call model_step_products(mdl, x, v, d, kx, mv, md, bx)
        call checks%check(all(kx == kx0) .and. all(mv == mv0) .and. all(md == md0) .and. &
                          all(bx == kx0), what//': model_step_products bitwise = CSC')
        call model_stiff_mass_apply(mdl, x, v, kx, mv)
        call checks%check(all(kx == kx0) .and. all(mv == mv0), &
                          what//': model_stiff_mass_apply bitwise = CSC')
        if (triples) then
            call block3_matvec_ks3(mdl%stiff_theta_b3, mdl%mass_s, x, v, d, kx, mv, md, bx)
            call checks%check(all(kx == kx0) .and. all(mv == mv0) .and. all(md == md0) .and. &
                              all(bx == kx0), what//': block3 ks3 bitwise = CSC')
            call block3_matvec_ks2(mdl%stiff_theta_b3, mdl%mass_s, x, v, kx, mv)
            call checks%check(all(kx == kx0) .and. all(mv == mv0), &
                              what//': block3 ks2 bitwise = CSC')
        end if
        call test_solves(what, mdl, triples)
        call test_mass_solver(what, mdl)
    end subroutine test_box

    !> J0 = M + c K_theta (hht's iteration matrix at dt = 0.0025): the solve by node
    !> triples against cholmod_solve2 on the same factor, one and seven right-hand sides.
    subroutine test_solves(what, mdl, triples)
        character(len=*), intent(in) :: what           !! case name
        type(model_t), intent(in) :: mdl               !! model
        logical, intent(in) :: triples                 !! expected: the triples' kernel
        integer, parameter :: K = 7
        type(csc_t) :: jac
        type(cholmod_t) :: ch
        real(dp) :: c, b(mdl%n_dofs, K), x(mdl%n_dofs, K), xc(mdl%n_dofs, K), r(mdl%n_dofs)
        integer :: stat, j
        logical :: ok
        c = 0.25_dp * 0.0025_dp**2
        jac = mdl%stiff
        call model_stiff_theta_values(mdl, jac%val)
        jac%val = mdl%mass_val + c * jac%val
        ch%keep_cholmod = .true.
        call chol_factor(ch, jac, stat)
        call checks%check(stat == STAT_OK, what//': J0 factorized')
        if (stat /= STAT_OK) return
        if (triples) then
            call checks%check(chol_kernel(ch) == KERNEL_TRIPLES, what//': solved by node triples')
        else
            call checks%check(chol_kernel(ch) == KERNEL_CHOLMOD, what//': cholmod_solve2 (not triples)')
        end if
        call random_number(b)
        b = b - 0.5_dp
        ok = .true.
        do j = 1, K
            call chol_solve(ch, b(:, j), x(:, j), stat)
            ok = ok .and. stat == STAT_OK
            call chol_solve_cholmod(ch, b(:, j), xc(:, j), stat)
            ok = ok .and. stat == STAT_OK
            call csc_matvec(jac, x(:, j), r)
            ok = ok .and. maxval(abs(r - b(:, j))) <= 1.0e-13_dp * maxval(abs(b(:, j)))
        end do
        call checks%check(ok, what//': solves run, residual at round-off')
        call checks%check(maxval(abs(x - xc)) <= 1.0e-13_dp * maxval(abs(xc)), &
                          what//': solve = cholmod_solve2 to round-off')
        call chol_solve_many(ch, b, xc, stat)
        if (triples) then   ! the same operations on each column
            call checks%check(stat == STAT_OK .and. all(xc == x), &
                              what//': solve_many = one solve a column, bitwise')
        else                ! cholmod_solve2's many-column order differs
            call checks%check(stat == STAT_OK .and. maxval(abs(x - xc)) <= 1.0e-13_dp * maxval(abs(x)), &
                              what//': solve_many = one solve a column')
        end if
        call chol_free(ch)
        ! without keep_cholmod: CHOLMOD's numerical factor released, the same solve
        call chol_factor(ch, jac, stat)
        call chol_solve(ch, b(:, 1), xc(:, 1), stat)
        call checks%check(stat == STAT_OK .and. all(xc(:, 1) == x(:, 1)), &
                          what//': one copy of the factor, the same solve')
        call chol_free(ch)
    end subroutine test_solves

    !> M^{-1} b through the scheme's mass solver (with every node free, the nodes' scalar
    !> mass with three right-hand sides): M x = b to round-off.
    subroutine test_mass_solver(what, mdl)
        character(len=*), intent(in) :: what           !! case name
        type(model_t), intent(in) :: mdl               !! model
        type(mass_solver_t) :: ms
        real(dp) :: b(mdl%n_dofs), x(mdl%n_dofs), r(mdl%n_dofs)
        integer :: stat
        type(csc_t) :: mm
        mm = mdl%stiff
        mm%val = mdl%mass_val
        call mass_solver_init(ms, mdl, stat)
        call checks%check(stat == STAT_OK .and. (ms%scalar .eqv. mdl%mass_scalar), &
                          what//': mass solver (scalar mass iff scalar blocks)')
        call random_number(b)
        call mass_solver_apply(ms, b, x, stat)
        call csc_matvec(mm, x, r)
        call checks%check(stat == STAT_OK .and. maxval(abs(r - b)) <= 1.0e-12_dp * maxval(abs(b)), &
                          what//': M (M^-1 b) = b')
        call mass_solver_free(ms)
    end subroutine test_mass_solver

    !> triple_ldl_build accepts a factor made of 3x3 blocks and refuses one that is not.
    subroutine test_triple_structure()
        type(triple_ldl_t) :: f
        logical :: ok
        integer :: k
        ! n = 6, two triples; block column 1 holds the block of rows 4..6
        call triple_ldl_build(f, 6, [0, 1, 2, 3, 4, 5], [0, 6, 11, 15, 18, 20, 21], &
                              [0, 1, 2, 3, 4, 5, 1, 2, 3, 4, 5, 2, 3, 4, 5, 3, 4, 5, 4, 5, 5], &
                              [(real(k, dp), k = 1, 21)], ok)
        call checks%check(ok .and. f%n == 6 .and. size(f%bi) == 1 .and. f%bi(1) == 2, &
                          'triple_ldl_build: 3x3 blocks accepted')
        call checks%check(ok .and. all(f%bx(:, 1) == [4, 5, 6, 9, 10, 11, 13, 14, 15]) &
                          .and. all(f%ld(:, 1) == [2, 3, 8]) .and. all(f%d == [1, 7, 12, 16, 19, 21]), &
                          'triple_ldl_build: blocks, diagonal blocks and D in place')
        ! column 2 without row 4: not a whole block
        call triple_ldl_build(f, 6, [0, 1, 2, 3, 4, 5], [0, 6, 10, 14, 17, 19, 20], &
                              [0, 1, 2, 3, 4, 5, 1, 2, 4, 5, 2, 3, 4, 5, 3, 4, 5, 4, 5, 5], &
                              [(real(k, dp), k = 1, 20)], ok)
        call checks%check(.not. ok .and. f%n == 0, 'triple_ldl_build: a broken block refused')
        call triple_ldl_build(f, 4, [0, 1, 2, 3], [0, 4, 7, 9, 10], &
                              [0, 1, 2, 3, 1, 2, 3, 2, 3, 3], [(real(k, dp), k = 1, 10)], ok)
        call checks%check(.not. ok, 'triple_ldl_build: n not a multiple of 3 refused')
    end subroutine test_triple_structure
end program test_blocks3d
