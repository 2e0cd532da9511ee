!> M^{-1} applications: a diagonal for lumped mass, linear_solver factors (CHOLMOD
!> LDL^T) of the compacted consistent mass otherwise (factorized once). When every node
!> block of M is m I (P1 with every component of every node free; 2x2 blocks in 2D, 3x3
!> in 3D), M = S (x) I_d with S the scalar mass on the nodes, and M x = b is solved as
!> S X = B with the d components as d right-hand sides: a factor 1/d the size of M's,
!> each of its entries used d times.
module mass_solver
    use kinds, only: dp
    use errors, only: STAT_OK
    use sparse, only: csc_t, csc_drop_zeros
    use linear_solver, only: factor_t, ls_factor, ls_solve, ls_solve_many, ls_free, ls_kernel, &
                             BACKEND_CHOLMOD
    use model, only: model_t, model_mass_definite, model_scalar_mass
    implicit none
    private

    !> Factors of M (or its inverse diagonal).
    type, public :: mass_solver_t
        logical :: lumped = .false.              !! diagonal mass
        real(dp), allocatable :: inv_diag(:)     !! 1 / diag(M) when lumped
        type(csc_t) :: mass                      !! M without structural zeros
        type(factor_t) :: lu                     !! its factors (LDL^T, or LU as fallback)
        integer, allocatable :: massless(:)      !! dofs with no inertia: x = 0 there
        logical :: scalar = .false.              !! M = S (x) I_d: lu holds the factors of S
        type(csc_t) :: s                         !! S, one row per node
        integer, allocatable :: first(:)         !! (nodes) the first of each node's d dofs
        real(dp), allocatable :: bs(:, :), xs(:, :)  !! (nodes, d) right-hand sides, solutions
    end type mass_solver_t

    public :: mass_solver_init, mass_solver_apply, mass_solver_free, mass_solver_name, &
              mass_solver_start, mass_solver_kernel

contains

    !> Prepare M^{-1}: factorizes a consistent M (one factorization). Dofs without
    !> inertia (redistributed mass: zero rows and columns) get a unit diagonal, so the
    !> rest is solved exactly and x = 0 there. A redistributed M is refused here when it
    !> is not positive definite (model_mass_definite's STAT_BAD_INPUT): an LDL^T of it
    !> that succeeds proves it definite (every pivot > 0); where the LDL^T did not run or
    !> did not succeed (LU instead: not symmetric, or a pivot <= 0), model_mass_definite
    !> decides.
    !> With `once` true the factors serve one solve (then freed): S may then be factorized
    !> supernodally, faster where its factor's columns are long (3D meshes from some 3 000
    !> to 10 000 nodes on), where a factor solved at every step stays simplicial (its
    !> solves faster).
    subroutine mass_solver_init(ms, mdl, stat, errmsg, once)
        type(mass_solver_t), intent(inout) :: ms            !! solver
        type(model_t), intent(in) :: mdl                    !! model
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        logical, intent(in), optional :: once               !! one solve only (default .false.)
        stat = STAT_OK
        call mass_solver_free(ms)
        ms%lu%ch%few_solves = .false.
        if (present(once)) ms%lu%ch%few_solves = once
        ms%lumped = mdl%lumped
        if (ms%lumped) then
            ms%inv_diag = 1.0_dp / mdl%mass_diag
        else
            ms%massless = mdl%massless_dofs
            if (size(ms%massless) > 0) then
                block
                    type(csc_t) :: m1
                    integer :: k, j, p
                    m1 = mdl%stiff
                    m1%val = mdl%mass_val
                    do k = 1, size(ms%massless)
                        j = ms%massless(k)
                        do p = m1%colptr(j) + 1, m1%colptr(j + 1)
                            if (m1%rowind(p) + 1 == j) m1%val(p) = 1.0_dp
                        end do
                    end do
                    call csc_drop_zeros(m1, ms%mass)
                end block
            else if (.not. mdl%mass_scalar) then
                block                                     ! (S alone is factorized otherwise)
                    type(csc_t) :: m1
                    m1 = mdl%stiff
                    m1%val = mdl%mass_val
                    call csc_drop_zeros(m1, ms%mass)
                end block
            end if
            if (mdl%mass_scalar .and. size(ms%massless) == 0) then
                call scalar_mass(stat)
                if (stat /= STAT_OK) return
                ms%scalar = .true.
                call ls_factor(ms%lu, ms%s, stat, errmsg)
            else
                call ls_factor(ms%lu, ms%mass, stat, errmsg)
            end if
            if (mdl%redistributed) call settle_definite()
        end if

    contains

        !> A redistributed M whose LDL^T did not run or did not succeed: model_mass_definite
        !> decides (its refusal replaces the factorization's status).
        subroutine settle_definite()
            integer :: st
            if (stat == STAT_OK .and. ms%lu%backend == BACKEND_CHOLMOD) return
            call model_mass_definite(mdl, st, errmsg)
            if (st /= STAT_OK) stat = st
        end subroutine settle_definite

        !> S from the node blocks of M (model_scalar_mass), and the right-hand sides' and
        !> solutions' arrays.
        subroutine scalar_mass(st)
            integer, intent(out) :: st   !! status
            call model_scalar_mass(mdl, ms%s, ms%first, st, errmsg)
            if (st /= STAT_OK) return
            allocate (ms%bs(size(ms%first), mdl%dim), ms%xs(size(ms%first), mdl%dim))
        end subroutine scalar_mass
    end subroutine mass_solver_init

    !> The start of a scheme that needs M^{-1}: prepare ms (one factorization, counted in
    !> factorizations, unless M is lumped) and solve the initial acceleration
    !> M a0 = L - B(u0) (SPEC section 1). `once`: the factors are freed after this solve
    !> (mass_solver_init).
    subroutine mass_solver_start(ms, mdl, bu, a, factorizations, stat, errmsg, once)
        type(mass_solver_t), intent(inout) :: ms            !! solver
        type(model_t), intent(in) :: mdl                    !! model (M, L)
        real(dp), intent(in) :: bu(:)                       !! B(u0)
        real(dp), intent(out) :: a(:)                       !! a0
        integer, intent(inout) :: factorizations            !! the scheme's count
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        logical, intent(in), optional :: once               !! one solve only (default .false.)
        call mass_solver_init(ms, mdl, stat, errmsg, once)
        if (stat /= STAT_OK) return
        if (.not. ms%lumped) factorizations = factorizations + 1
        call mass_solver_apply(ms, mdl%load - bu, a, stat, errmsg)
    end subroutine mass_solver_start

    !> x = M^{-1} b.
    subroutine mass_solver_apply(ms, b, x, stat, errmsg)
        type(mass_solver_t), intent(inout) :: ms            !! solver
        real(dp), intent(in) :: b(:)                        !! right-hand side
        real(dp), intent(out) :: x(:)                       !! solution
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: g, c
        if (ms%lumped) then
            x = ms%inv_diag * b
            stat = STAT_OK
        else if (ms%scalar) then
            do c = 1, size(ms%bs, 2)
                do g = 1, size(ms%first)
                    ms%bs(g, c) = b(ms%first(g) + c - 1)
                end do
            end do
            call ls_solve_many(ms%lu, ms%s, ms%bs, ms%xs, stat, errmsg)
            do c = 1, size(ms%bs, 2)
                do g = 1, size(ms%first)
                    x(ms%first(g) + c - 1) = ms%xs(g, c)
                end do
            end do
        else
            call ls_solve(ms%lu, ms%mass, b, x, stat, errmsg)
            if (allocated(ms%massless)) x(ms%massless) = 0.0_dp
        end if
    end subroutine mass_solver_apply

    !> Release the factors and the matrices they were computed from.
    subroutine mass_solver_free(ms)
        type(mass_solver_t), intent(inout) :: ms   !! solver
        type(csc_t) :: empty
        call ls_free(ms%lu)
        if (allocated(ms%inv_diag)) deallocate (ms%inv_diag)
        if (allocated(ms%bs)) deallocate (ms%bs, ms%xs)
        if (allocated(ms%first)) deallocate (ms%first)
        ms%mass = empty
        ms%s = empty
        ms%scalar = .false.
    end subroutine mass_solver_free

    !> The backend that applies M^{-1}: 'diagonal' (lumped mass) or the factors'.
    pure function mass_solver_name(ms) result(name)
        type(mass_solver_t), intent(in) :: ms   !! solver
        character(len=:), allocatable :: name
        if (ms%lumped) then
            name = 'diagonal'
        else
            name = trim(ms%lu%backend)
        end if
    end function mass_solver_name

    !> The triangular solve of the M^{-1} applications (ls_kernel; 'diagonal' for
    !> lumped mass).
    pure function mass_solver_kernel(ms) result(name)
        type(mass_solver_t), intent(in) :: ms   !! solver
        character(len=:), allocatable :: name
        if (ms%lumped) then
            name = 'diagonal'
        else
            name = ls_kernel(ms%lu)
        end if
    end function mass_solver_kernel
end module mass_solver
