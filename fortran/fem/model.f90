!> The semi-discrete model M u'' + B(u) = L, built on a mesh from plain parameters: free dofs
!> (Dirichlet conditions eliminated), assembled M, K, K_theta and L (one shared
!> CSC pattern), contact facets and the probe.
module model
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use kinds, only: dp
    use stop_signal, only: check_stop
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, STAT_INTERNAL, raise, oom_text, &
                      mb_text, has_room, OOM_HINT_MESH
    use mesh, only: mesh_t, mesh_check, mesh_group_nodes, mesh_group_facets, mesh_parts
    use fe_p1, only: p1_lame, p1_stiffness, p1_mass
    use simplex_geometry, only: simplex_measure, simplex_diameter, euclid_length
    use dense_lu, only: dense_lu_factor, dense_lu_solve
    use sparse, only: csc_t, csc_find, csc_matvec_t_values, csc_swap_values, block2_csc_values, &
                      csc_from_coo, &
                      block3_csc_values, block2_t, block2_from_csc, &
                      block2_matvec, block2_matvec_km, block2_scalar_blocks, block2_matvec_ks2, &
                      block2_matvec_ks3, block3_t, block3_from_csc, block3_matvec, block3_matvec_km, &
                      block3_scalar_blocks, block3_matvec_ks2, block3_matvec_ks3
    use mass_redistribution, only: mass_region, mass_redistribute
    use text, only: int_text, real_text
    use cholmod, only: cholmod_t, chol_factor, chol_free
    use nitsche_contact, only: contact_t, contact_init, contact_eval, contact_max_rank, &
                               facet_pressure, &
                               facet_shape, MAX_E, MAX_FN, QUAD_EXACT, QUAD_GAUSS
    use alm_contact, only: alm_t, alm_init, alm_probe, ALM_OFF
    implicit none
    private

    integer, parameter, public :: MASS_CONSISTENT = 1      !! mass kinds
    integer, parameter, public :: MASS_LUMPED = 2
    integer, parameter, public :: MASS_REDISTRIBUTED = 3
    integer, parameter, public :: INITIAL_REST = 1         !! initial conditions
    integer, parameter, public :: INITIAL_VELOCITY = 2
    integer, parameter, public :: INITIAL_COMPRESSED_BAR = 3
    !> Most contact facets that can hold the probe (a node of Gamma_C and its facets).
    integer, parameter, public :: MAX_PROBE = 32
    !> Cells assembled between two reads of the stop flag (about 0.1 s of assembly).
    integer, parameter :: ASSEMBLY_CHUNK = 10000

    !> The plain parameters a model is built from (docs/scenes.md names the keys).
    type, public :: model_params_t
        character(len=1024) :: name = ''          !! what messages start with (the scene file)
        character(len=1100) :: mesh_name = ''     !! how messages name the mesh
        character(len=256) :: clamped = ''        !! groups with u = 0
        character(len=256) :: slip_x = ''         !! groups with u_x = 0
        character(len=256) :: slip_y = ''         !! groups with u_y = 0
        character(len=256) :: slip_z = ''         !! groups with u_z = 0 (3D)
        character(len=256) :: contact = ''        !! contact boundary groups ('' = none)
        real(dp) :: young = 1.0_dp                !! Young's modulus E
        real(dp) :: poisson = 0.0_dp              !! Poisson ratio
        real(dp) :: density = 1.0_dp              !! rho
        real(dp) :: gravity(3) = 0.0_dp           !! body acceleration g (f = rho g), first dim used
        integer :: mass = MASS_CONSISTENT         !! MASS_CONSISTENT | MASS_LUMPED | MASS_REDISTRIBUTED
        logical :: penalty = .false.              !! penalty contact instead of Nitsche
        integer :: multiplier = ALM_OFF           !! augmented Lagrangian: ALM_INTEGRAL | ALM_NODAL
        integer :: nitsche_theta = 1              !! -1, 0 or 1
        real(dp) :: gamma0 = 10.0_dp              !! gamma_N = gamma0 / h_T
        real(dp) :: obstacle_point(3) = 0.0_dp    !! a point of the obstacle plane
        real(dp) :: obstacle_normal(3) = [0.0_dp, -1.0_dp, 0.0_dp] !! normal into the obstacle
        real(dp) :: probe(3) = 0.0_dp             !! probe point on Gamma_C
        logical :: probe_given = .true.           !! the scene gives probe (else the bar's default)
        integer :: quadrature = QUAD_EXACT        !! QUAD_EXACT | QUAD_GAUSS
        integer :: quad_points = 3                !! Gauss points per facet (QUAD_GAUSS)
        integer :: initial = INITIAL_REST         !! INITIAL_REST | INITIAL_VELOCITY | INITIAL_COMPRESSED_BAR
        real(dp) :: amplitude = 0.0_dp            !! compressed_bar lift
        real(dp) :: velocity(3) = 0.0_dp          !! INITIAL_VELOCITY velocity
        real(dp) :: length = 1.0_dp               !! compressed_bar: the lift falls to 0 over it
        logical :: length_from_mesh = .false.     !! compressed_bar: over the body's extent instead
    end type model_params_t

    !> Everything constant in time.
    type, public :: model_t
        integer :: dim = 0                        !! 1, 2 or 3
        integer :: n_dofs = 0                     !! free dofs
        integer :: ndof_e = 0                     !! dofs per cell
        type(mesh_t) :: msh                       !! the mesh
        integer, allocatable :: dof(:, :)         !! (dim, n_nodes) free dof number, 0 = constrained
        integer, allocatable :: dof_node(:)       !! (n_dofs) node of each free dof
        integer, allocatable :: dof_comp(:)       !! (n_dofs) component of each free dof
        type(csc_t) :: stiff                      !! K; its pattern is also M's and K_theta's
        real(dp), allocatable :: mass_val(:)      !! (stiff%nnz) M (consistent or lumped) on K's pattern
        real(dp), allocatable :: stiff_theta_val(:) !! (stiff%nnz) K_theta = K - sum theta |F| / gamma s s^T
                                                    !! on it; freed when blocked (model_stiff_theta_values)
        logical :: blocked = .false.              !! K_theta also in node blocks (2x2 in 2D, 3x3 in 3D)
        type(block2_t) :: stiff_theta_b           !! its node-block copy (fast products; 2D)
        type(block2_t) :: mass_b                  !! node-block copy of M (same blocks; 2D; empty when mass_scalar)
        type(block3_t) :: stiff_theta_b3          !! the 3x3 node-block copy of K_theta (3D)
        type(block3_t) :: mass_b3                 !! the 3x3 node-block copy of M (3D; empty when mass_scalar)
        logical :: mass_scalar = .false.          !! every block of M is m I (no node with a constrained dof)
        real(dp), allocatable :: mass_s(:)        !! then the m of each block, on K_theta's block pattern
        logical :: lumped = .false.               !! M is diagonal
        real(dp), allocatable :: mass_diag(:)     !! (n_dofs) diagonal of M when lumped
        logical :: redistributed = .false.        !! mass = 'redistributed': checked definite when
                                                  !! a run starts (model_mass_definite)
        logical, allocatable :: massless(:)       !! (n_dofs) no inertia (redistributed mass)
        integer, allocatable :: massless_dofs(:)  !! those dofs
        real(dp), allocatable :: load(:)          !! (n_dofs) L = int rho g . v
        logical :: has_contact = .false.          !! a contact boundary exists
        type(contact_t) :: ct                     !! contact facets
        type(alm_t) :: alm                        !! augmented Lagrangian multipliers (kind ALM_OFF: none)
        real(dp) :: normal(3) = 0.0_dp            !! unit normal (into the obstacle)
        integer :: n_probe = 0                    !! facets holding the probe (0, 1, or those sharing its edge or node)
        integer :: probe_facet(MAX_PROBE) = 0     !! their indices in ct
        real(dp) :: probe_shape(MAX_FN, MAX_PROBE) = 0.0_dp !! facet shape values at the probe on each
        integer :: probe_node(MAX_PROBE) = 0      !! the facet node at the probe (shape value 1, the others 0), or 0
        character(len=4096) :: notes = ''          !! warnings and notes for the user, one per line
        character(len=1024) :: name = ''          !! what messages start with (model_params_t's)
        character(len=1100) :: mesh_name = ''     !! how messages name the mesh (model_params_t's)
        real(dp) :: gamma0_min = 0.0_dp           !! smallest gamma0 keeping K_theta PSD (element bound, theta = 1)
    end type model_t

    public :: model_build, model_eval_b, model_apply_jacobian, model_initial, model_lift_length, &
              model_check_initial, &
              model_probe, model_mass_apply, model_stiff_apply, model_full_field, &
              model_step_products, model_stiff_mass_apply, model_stiff_theta_values, &
              model_mass_definite, model_scalar_mass

contains

    !> Build the model on a mesh from plain parameters. Errors (STAT_BAD_INPUT) start
    !> with prm%name and name the key: an unusable mesh, a group the mesh lacks, a probe
    !> off Gamma_C. A stop signal caught during the assembly (module stop_signal) gives
    !> STAT_INTERRUPTED.
    subroutine model_build(msh, prm, mdl, stat, errmsg)
        type(mesh_t), intent(in) :: msh                     !! mesh (copied into the model)
        type(model_params_t), intent(in) :: prm             !! parameters
        type(model_t), intent(out) :: mdl                   !! model
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=1024) :: msg
        real(dp) :: lambda, mu
        integer, allocatable :: facets(:)
        integer :: dim, j, parts, c0
        logical :: faces
        stat = STAT_OK
        msg = ''
        mdl%name = prm%name
        mdl%mesh_name = prm%mesh_name
        mdl%msh = msh
        call mesh_check(mdl%msh, stat, msg)
        if (stat /= STAT_OK) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &mesh: '//trim(msg))
            return
        end if
        dim = mdl%msh%dim
        mdl%dim = dim
        parts = mesh_parts(mdl%msh)
        if (parts > 1) call note(mdl, 'warning: '//trim(prm%mesh_name)//' has '// &
                                 int_text(parts)//' parts that share no node, each moving on '// &
                                 'its own (coincident nodes that were not merged?)')
        mdl%ndof_e = dim * (dim + 1)
        mdl%normal = 0.0_dp
        mdl%normal(1:dim) = prm%obstacle_normal(1:dim) / norm2(prm%obstacle_normal(1:dim))
        call p1_lame(prm%young, prm%poisson, lambda, mu)

        call number_dofs(mdl, prm, stat, msg)
        if (stat /= STAT_OK) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &boundary '//trim(msg) &
                       //' ('//trim(prm%mesh_name)//')')
            return
        end if
        if (mdl%n_dofs == 0) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &boundary clamped: no free dofs ' &
                       //'(every node is clamped or slip-fixed: clamped = '''//trim(prm%clamped) &
                       //''' in '//trim(prm%mesh_name)//')')
            return
        end if
        call cell_pattern(mdl, mdl%stiff, stat)
        if (stat == STAT_OK) then
            ! M and K_theta on the pattern, and the node-block copies of K_theta and M to
            ! come: 24 bytes an entry at the least
            if (.not. has_room(24.0_dp * mdl%stiff%nnz)) stat = STAT_INTERNAL
        end if
        if (stat /= STAT_OK) then
            call raise(stat, errmsg, STAT_INTERNAL, oom_text('the assembly', 'the matrices of '// &
                       int_text(mdl%n_dofs)//' dofs have '//int_text(mdl%stiff%nnz)// &
                       ' entries, 36 bytes each for K, M and K_theta ('// &
                       mb_text(36.0_dp * mdl%stiff%nnz)//')', OOM_HINT_MESH))
            return
        end if
        ! in chunks of cells, with the stop flag read between them (some 2 s on a mesh of
        ! 1.8e5 tetrahedra): the sums are made in the same order as in one pass
        call assemble_start(mdl, prm)
        do c0 = 1, mdl%msh%n_cells, ASSEMBLY_CHUNK
            call check_stop('the assembly', stat, errmsg)
            if (stat /= STAT_OK) return
            call assemble_cells(mdl, prm, lambda, mu, c0, &
                                min(mdl%msh%n_cells, c0 + ASSEMBLY_CHUNK - 1))
        end do
        call assemble_end(mdl)

        call mesh_group_facets(mdl%msh, prm%contact, facets, stat, msg)
        if (stat /= STAT_OK) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &boundary contact: ' &
                       //trim(msg)//' ('//trim(prm%mesh_name)//')')
            return
        end if
        mdl%has_contact = size(facets) > 0
        allocate (mdl%massless(mdl%n_dofs))
        mdl%massless = .false.
        if (prm%mass == MASS_REDISTRIBUTED) then
            mdl%redistributed = .true.
            call redistribute(mdl, facets, stat, msg)
            if (stat /= STAT_OK) then
                call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &scheme mass: ' &
                           //trim(msg)//' ('//trim(prm%mesh_name)//')')
                return
            end if
        end if
        mdl%massless_dofs = pack([(j, j=1, mdl%n_dofs)], mdl%massless)
        call contact_init(mdl%ct, mdl%msh, facets, mdl%dof, prm%young, lambda, mu, &
                          mdl%normal(1:dim), prm%obstacle_point(1:dim), prm%gamma0, &
                          prm%nitsche_theta, prm%quadrature, &
                          prm%quad_points, stat, msg, &
                          penalty=prm%penalty .or. prm%multiplier /= ALM_OFF)
        if (stat /= STAT_OK) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &boundary contact: ' &
                       //trim(msg))
            return
        end if
        if (mdl%has_contact .and. prm%multiplier /= ALM_OFF) &
            call alm_init(mdl%alm, mdl%ct, prm%multiplier)
        if (mdl%has_contact) then
            call check_normal(mdl, faces)
            if (faces) call check_gap(mdl)      ! else the normal is what to fix
            call check_gamma0(mdl, prm, lambda, mu, stat, msg)
            if (stat /= STAT_OK) then
                call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &contact gamma0: '//trim(msg))
                return
            end if
        else
            call note(mdl, 'warning: no contact boundary (&boundary contact = '''//trim(prm%contact)// &
                      '''): the probe reports nothing (u_n, v_n, p_n are 0 in trace.csv)')
        end if
        call add_theta_term(mdl)
        ! the node-block copies of K_theta and M (8 bytes an entry each and their work)
        stat = STAT_OK
        if (mdl%dim >= 2 .and. .not. has_room(20.0_dp * mdl%stiff%nnz)) stat = STAT_INTERNAL
        if (stat == STAT_OK) call block_copy(mdl, stat, msg)
        if (stat == STAT_INTERNAL) then
            call raise(stat, errmsg, STAT_INTERNAL, oom_text('the assembly (the node-block '// &
                       'copies of K_theta and M)', 'the matrices of '//int_text(mdl%n_dofs)// &
                       ' dofs have '//int_text(mdl%stiff%nnz)//' entries', OOM_HINT_MESH))
            return
        end if
        if (stat /= STAT_OK) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': '//trim(msg))
            return
        end if
        ! K_theta in its node blocks only: its products use them, and the few readers of
        ! its CSC values (J0, the API) read them back (model_stiff_theta_values)
        if (mdl%blocked) deallocate (mdl%stiff_theta_val)
        if (mdl%has_contact) then
            call snap_probe(mdl, prm, stat, msg)
            if (stat /= STAT_OK) then
                call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &contact probe: '//trim(msg))
                return
            end if
        end if

    end subroutine model_build

    !> Dirichlet masks -> free dof numbering (node-major).
    subroutine number_dofs(mdl, prm, st, m)
        type(model_t), intent(inout) :: mdl          !! model being built
        type(model_params_t), intent(in) :: prm      !! parameters
        integer, intent(out) :: st                   !! status
        character(len=*), intent(inout) :: m         !! message
        logical, allocatable :: fixed(:, :), mask(:)
        integer :: i, k, n, dim
        dim = mdl%dim
        allocate (fixed(dim, mdl%msh%n_nodes), mask(mdl%msh%n_nodes))
        fixed = .false.
        call group_mask('clamped', prm%clamped)
        if (st /= STAT_OK) return
        do k = 1, dim
            fixed(k, :) = mask
        end do
        call group_mask('slip_x', prm%slip_x)
        if (st /= STAT_OK) return
        fixed(1, :) = fixed(1, :) .or. mask
        call group_mask('slip_y', prm%slip_y)
        if (st /= STAT_OK) return
        if (dim == 1 .and. any(mask)) then
            st = STAT_BAD_INPUT
            m = 'slip_y: a 1D model has no y component'
            return
        end if
        if (dim >= 2) fixed(2, :) = fixed(2, :) .or. mask
        call group_mask('slip_z', prm%slip_z)
        if (st /= STAT_OK) return
        if (dim < 3 .and. any(mask)) then
            st = STAT_BAD_INPUT
            m = 'slip_z: a '//merge('1D', '2D', dim == 1)//' model has no z component'
            return
        end if
        if (dim == 3) fixed(3, :) = fixed(3, :) .or. mask
        allocate (mdl%dof(dim, mdl%msh%n_nodes))
        n = 0
        do i = 1, mdl%msh%n_nodes
            do k = 1, dim
                if (fixed(k, i)) then
                    mdl%dof(k, i) = 0
                else
                    n = n + 1
                    mdl%dof(k, i) = n
                end if
            end do
        end do
        mdl%n_dofs = n
        allocate (mdl%dof_node(n), mdl%dof_comp(n))
        do i = 1, mdl%msh%n_nodes
            do k = 1, dim
                if (mdl%dof(k, i) > 0) then
                    mdl%dof_node(mdl%dof(k, i)) = i
                    mdl%dof_comp(mdl%dof(k, i)) = k
                end if
            end do
        end do

    contains

        !> mask = the nodes of the boundary groups `groups` (the &boundary key `key`);
        !> a failure's message starts with the key.
        subroutine group_mask(key, groups)
            character(len=*), intent(in) :: key      !! &boundary key, for the message
            character(len=*), intent(in) :: groups   !! its group names
            mask = .false.
            call mesh_group_nodes(mdl%msh, groups, mask, st, m)
            if (st /= STAT_OK) m = key//': '//trim(m)
        end subroutine group_mask
    end subroutine number_dofs

    !> The start of the assembly of M, K, K_theta (= K until add_theta_term) and L on the
    !> pattern (cell_pattern): M and L zero (K's values are zero on the new pattern).
    pure subroutine assemble_start(mdl, prm)
        type(model_t), intent(inout) :: mdl          !! model being built
        type(model_params_t), intent(in) :: prm      !! parameters
        mdl%mass_val = mdl%stiff%val
        allocate (mdl%load(mdl%n_dofs))
        mdl%load = 0.0_dp
        mdl%lumped = prm%mass == MASS_LUMPED
    end subroutine assemble_start

    !> The contributions of cells c_first to c_last to M, K and L, added in cell order.
    pure subroutine assemble_cells(mdl, prm, lambda, mu, c_first, c_last)
        type(model_t), intent(inout) :: mdl          !! model being built (assemble_start)
        type(model_params_t), intent(in) :: prm      !! parameters
        real(dp), intent(in) :: lambda, mu           !! Lame parameters
        integer, intent(in) :: c_first, c_last       !! cells
        integer :: c, a, b, i, j, ne, dim, cd(MAX_E), pos(MAX_E, MAX_E)
        real(dp) :: xe(3, 4), ke(MAX_E, MAX_E), me(MAX_E, MAX_E)
        real(dp) :: vol
        dim = mdl%dim
        ne = mdl%ndof_e
        do c = c_first, c_last
            call cell_positions(mdl, c, cd(1:ne), pos(1:ne, 1:ne))
            xe(1:dim, 1:dim + 1) = mdl%msh%x(:, mdl%msh%cells(:, c))
            call p1_stiffness(dim, xe(1:dim, 1:dim + 1), lambda, mu, prm%young, ke(1:ne, 1:ne))
            call p1_mass(dim, xe(1:dim, 1:dim + 1), prm%density, mdl%lumped, me(1:ne, 1:ne))
            do b = 1, ne
                do a = 1, ne
                    i = pos(a, b)
                    if (i == 0) cycle
                    mdl%stiff%val(i) = mdl%stiff%val(i) + ke(a, b)
                    mdl%mass_val(i) = mdl%mass_val(i) + me(a, b)
                end do
            end do
            vol = abs(simplex_measure(dim, xe(1:dim, 1:dim + 1)))
            do a = 1, dim + 1
                do j = 1, dim
                    i = cd(dim * (a - 1) + j)
                    if (i > 0) mdl%load(i) = mdl%load(i) + prm%density * prm%gravity(j) * vol / (dim + 1)
                end do
            end do
        end do
    end subroutine assemble_cells

    !> The end of the assembly: K_theta = K, and the lumped mass's diagonal.
    pure subroutine assemble_end(mdl)
        type(model_t), intent(inout) :: mdl          !! model being built (every cell added)
        integer :: j
        mdl%stiff_theta_val = mdl%stiff%val
        if (mdl%lumped) then
            allocate (mdl%mass_diag(mdl%n_dofs))
            do j = 1, mdl%n_dofs
                mdl%mass_diag(j) = mdl%mass_val(csc_find(mdl%stiff, j, j))
            end do
        end if
    end subroutine assemble_end

    !> Free dofs of cell c (0 = constrained).
    pure subroutine cell_dofs(mdl, c, cd)
        type(model_t), intent(in) :: mdl             !! model
        integer, intent(in) :: c                     !! cell
        integer, intent(out) :: cd(:)                !! (ndof_e) its free dofs
        integer :: a, k
        do a = 1, mdl%dim + 1
            do k = 1, mdl%dim
                cd(mdl%dim * (a - 1) + k) = mdl%dof(k, mdl%msh%cells(a, c))
            end do
        end do
    end subroutine cell_dofs

    !> The matrices' pattern (values zero): (i, j) is stored when the free dofs i and j
    !> belong to nodes of a common cell, rows ascending in each column: the pattern the
    !> cells' triplets summed by csc_from_coo gave, built from the nodes' cells instead
    !> (n + (dim + 1) n_cells integers of work, where the triplets took 36 bytes for each
    !> of the ndof_e^2 entries of every cell: 160 MB for the 3D box at 19 440 dofs, the
    !> set-up's peak there).
    pure subroutine cell_pattern(mdl, a, stat)
        type(model_t), intent(in) :: mdl             !! model (dofs numbered)
        type(csc_t), intent(out) :: a                !! pattern
        integer, intent(out) :: stat                 !! STAT_OK, STAT_INTERNAL (out of memory)
        integer, allocatable :: first(:), cells(:), mark(:), buf(:)
        integer :: nn, nc, nv, i, j, k, c, p, q, t, r, cnt, pass, node, other, row
        stat = STAT_OK
        nn = mdl%msh%n_nodes
        nc = mdl%msh%n_cells
        nv = size(mdl%msh%cells, 1)
        ! the cells of each node (CSR)
        allocate (first(nn + 1), cells(nv * nc), stat=stat)
        if (stat /= 0) then
            stat = STAT_INTERNAL
            return
        end if
        first = 0
        do c = 1, nc
            do k = 1, nv
                first(mdl%msh%cells(k, c) + 1) = first(mdl%msh%cells(k, c) + 1) + 1
            end do
        end do
        first(1) = 1
        do i = 1, nn
            first(i + 1) = first(i + 1) + first(i)
        end do
        do c = 1, nc
            do k = 1, nv
                node = mdl%msh%cells(k, c)
                cells(first(node)) = c
                first(node) = first(node) + 1
            end do
        end do
        do i = nn, 1, -1
            first(i + 1) = first(i)
        end do
        first(1) = 1
        a%n = mdl%n_dofs
        allocate (a%colptr(a%n + 1), mark(a%n), buf(a%n), stat=stat)
        if (stat /= 0) then
            stat = STAT_INTERNAL
            return
        end if
        ! two passes over the columns: count, then store
        do pass = 1, 2
            mark = 0
            cnt = 0
            do j = 1, a%n
                node = mdl%dof_node(j)
                t = 0
                do p = first(node), first(node + 1) - 1
                    c = cells(p)
                    do q = 1, nv
                        other = mdl%msh%cells(q, c)
                        do r = 1, mdl%dim
                            row = mdl%dof(r, other)
                            if (row == 0) cycle
                            if (mark(row) == j) cycle
                            mark(row) = j
                            t = t + 1
                            buf(t) = row
                        end do
                    end do
                end do
                if (pass == 1) then
                    a%colptr(j) = cnt
                else
                    call sort_ints(buf(1:t))
                    a%rowind(cnt + 1:cnt + t) = buf(1:t) - 1
                end if
                cnt = cnt + t
            end do
            if (pass == 1) then
                a%colptr(a%n + 1) = cnt
                a%nnz = cnt
                allocate (a%rowind(cnt), a%val(cnt), stat=stat)
                if (stat /= 0) then
                    stat = STAT_INTERNAL
                    return
                end if
                a%val = 0.0_dp
            end if
        end do

    contains

        !> Sort a few integers ascending (insertion: a column holds some tens of rows).
        pure subroutine sort_ints(v)
            integer, intent(inout) :: v(:)   !! sorted in place
            integer :: ii, jj, key
            do ii = 2, size(v)
                key = v(ii)
                jj = ii - 1
                do while (jj >= 1)
                    if (v(jj) <= key) exit
                    v(jj + 1) = v(jj)
                    jj = jj - 1
                end do
                v(jj + 1) = key
            end do
        end subroutine sort_ints
    end subroutine cell_pattern

    !> The free dofs cd of cell c and the positions pos(a, b) of its entries (cd(a), cd(b))
    !> in the matrices' pattern (0 where a dof is constrained): found again where needed,
    !> not stored (ndof_e^2 integers a cell would be as large as the pattern's values).
    pure subroutine cell_positions(mdl, c, cd, pos)
        type(model_t), intent(in) :: mdl             !! model (pattern assembled)
        integer, intent(in) :: c                     !! cell
        integer, intent(out) :: cd(:)                !! (ndof_e) its free dofs
        integer, intent(out) :: pos(:, :)            !! (ndof_e, ndof_e) positions
        integer :: a, b
        call cell_dofs(mdl, c, cd)
        do b = 1, size(cd)
            do a = 1, size(cd)
                pos(a, b) = 0
                if (cd(a) > 0 .and. cd(b) > 0) pos(a, b) = csc_find(mdl%stiff, cd(a), cd(b))
            end do
        end do
    end subroutine cell_positions

    !> K_theta = K - sum_f theta |F| / gamma_N s_f s_f^T.
    pure subroutine add_theta_term(mdl)
        type(model_t), intent(inout) :: mdl          !! model being built
        integer :: f, a, b, i, cd(MAX_E), pos(MAX_E, MAX_E)
        real(dp) :: coef
        if (mdl%ct%theta == 0) return     ! theta = 0, or penalty
        do f = 1, mdl%ct%n_facets
            coef = mdl%ct%theta * mdl%ct%measure(f) / mdl%ct%gamma(f)
            call cell_positions(mdl, mdl%ct%cell(f), cd(1:mdl%ndof_e), &
                                pos(1:mdl%ndof_e, 1:mdl%ndof_e))
            do b = 1, mdl%ndof_e
                do a = 1, mdl%ndof_e
                    i = pos(a, b)
                    if (i == 0) cycle
                    mdl%stiff_theta_val(i) = mdl%stiff_theta_val(i) &
                                             - coef * mdl%ct%s(a, f) * mdl%ct%s(b, f)
                end do
            end do
        end do
    end subroutine add_theta_term

    !> Redistributed mass: no inertia on the contact nodes (module mass_redistribution).
    subroutine redistribute(mdl, facets, st, m)
        type(model_t), intent(inout) :: mdl          !! model being built
        integer, intent(in) :: facets(:)             !! contact facets (mesh facet indices)
        integer, intent(out) :: st                   !! status
        character(len=*), intent(inout) :: m         !! message
        logical, allocatable :: contact_node(:), region(:)
        integer, parameter :: LAYERS = 4
        allocate (contact_node(mdl%msh%n_nodes), region(mdl%msh%n_nodes))
        contact_node = .false.
        if (size(facets) > 0) contact_node(reshape(mdl%msh%facets(:, facets), [size(facets) &
                                           * size(mdl%msh%facets, 1)])) = .true.
        call mass_region(mdl%msh%cells, contact_node, LAYERS, region)
        call csc_swap_values(mdl%stiff, mdl%mass_val)     ! mdl%stiff reads as M
        call mass_redistribute(mdl%stiff, mdl%dof_node, mdl%dof_comp, mdl%msh%x, contact_node, &
                               region, mdl%massless, st, m)
        call csc_swap_values(mdl%stiff, mdl%mass_val)
    end subroutine redistribute

    !> Whether the redistributed M is positive definite on the dofs that keep inertia
    !> (e_kin = v.M v / 2 >= 0): the correction that keeps the mass and first moments can
    !> make it indefinite where few cell layers stand behind the contact nodes (a short
    !> body, contact on opposite sides). Refused (STAT_BAD_INPUT, the message naming
    !> &scheme mass) when it is not. One LDL^T factorization of M with a unit diagonal on
    !> the massless dofs, released at once (but see `keep`): a pivot <= 0 means
    !> indefinite. Called when a run starts, where M is not factorized anyway (the
    !> theta-scheme), or where its factorization did not settle it (mass_solver: an
    !> LDL^T of M that succeeds proves it definite, so the Newmark family pays no second
    !> factorization); the model alone (model_build) does not check. STAT_OK at once for a mass that is not redistributed.
    !> When every node block of M is m I (mass_scalar: M = S (x) I_d, the massless nodes'
    !> blocks 0 I), M with a unit diagonal on the massless dofs is S with a unit diagonal
    !> on the massless nodes, (x) I_d: the same eigenvalues, each d times, so S is
    !> factorized instead (1/d the size, about 1/d^3 of the flops). Otherwise, with
    !> `keep`, M's factorization is made in it and left there: its symbolic analysis (the
    !> orderings tried, most of the cost in 2D) is that of every matrix on the model's
    !> pattern, which the next chol_factor of J0 = M + c K_theta with it then reuses.
    !> With `factorizations`, the check's factorization (of S or M) is added to it when
    !> it succeeds, as a scheme counts its own.
    subroutine model_mass_definite(mdl, stat, errmsg, keep, factorizations)
        type(model_t), intent(in) :: mdl                    !! model
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        type(cholmod_t), intent(inout), optional :: keep    !! factors (replaced; kept)
        integer, intent(inout), optional :: factorizations  !! a scheme's count (+1 if factorized)
        real(dp), allocatable :: val(:)
        type(cholmod_t) :: ch
        type(csc_t) :: sm
        integer, allocatable :: first(:)
        integer :: j, p, st
        logical :: scalar
        character(len=1024) :: m
        stat = STAT_OK
        if (.not. mdl%redistributed) return
        m = ''
        scalar = mdl%mass_scalar
        if (scalar) then
            call model_scalar_mass(mdl, sm, first, st, m)
            if (st /= STAT_OK) then
                call raise(stat, errmsg, st, trim(m))
                return
            end if
            ! S's unit diagonal on the massless nodes (every dof of a node massless, or
            ! none: else M is factorized itself)
            do j = 1, sm%n
                if (any(mdl%massless(first(j):first(j) + mdl%dim - 1) .neqv. &
                        mdl%massless(first(j)))) scalar = .false.
                if (.not. mdl%massless(first(j))) cycle
                do p = sm%colptr(j) + 1, sm%colptr(j + 1)
                    if (sm%rowind(p) + 1 == j) sm%val(p) = 1.0_dp
                end do
            end do
        end if
        if (scalar) then
            call chol_factor(ch, sm, st, m)
            call chol_free(ch)
        else
            allocate (val, source=mdl%mass_val)
            do j = 1, mdl%stiff%n
                if (.not. mdl%massless(j)) cycle
                do p = mdl%stiff%colptr(j) + 1, mdl%stiff%colptr(j + 1)
                    if (mdl%stiff%rowind(p) + 1 == j) val(p) = 1.0_dp
                end do
            end do
            if (present(keep)) then
                call chol_factor(keep, mdl%stiff, st, m, val)
            else
                call chol_factor(ch, mdl%stiff, st, m, val)
                call chol_free(ch)
            end if
        end if
        if (st == STAT_OK .and. present(factorizations)) factorizations = factorizations + 1
        if (st == STAT_NUMERIC) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(mdl%name)//': &scheme mass: '// &
                       'mass redistribution: the mass matrix it gives '// &
                       'is not positive definite on this mesh (too few cell layers behind the '// &
                       'contact nodes); use a finer mesh, or mass = ''consistent'' or '// &
                       '''lumped'' ('//trim(mdl%mesh_name)//')')
        else if (st /= STAT_OK) then
            call raise(stat, errmsg, st, trim(m))
        end if
    end subroutine model_mass_definite

    !> S, the node matrix of M = S (x) I_d when mass_scalar (one row and column a node
    !> with free dofs, the m of M's node blocks: mass_s on K_theta's block pattern), and
    !> first(g), the first of node g's d consecutive dofs.
    subroutine model_scalar_mass(mdl, s, first, stat, errmsg)
        type(model_t), intent(in) :: mdl                    !! model (mass_scalar)
        type(csc_t), intent(out) :: s                       !! S
        integer, allocatable, intent(out) :: first(:)       !! (nodes) first dof of each
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer, allocatable :: grp(:), rows(:), cols(:), bfirst(:), row_ptr(:), col1(:)
        integer :: g, k, ng
        if (mdl%dim == 3) then
            bfirst = mdl%stiff_theta_b3%first
            row_ptr = mdl%stiff_theta_b3%row_ptr
            col1 = mdl%stiff_theta_b3%col1
        else
            bfirst = mdl%stiff_theta_b%first
            row_ptr = mdl%stiff_theta_b%row_ptr
            col1 = mdl%stiff_theta_b%col1
        end if
        ng = size(bfirst) - 1
        first = bfirst(1:ng)
        allocate (grp(mdl%n_dofs), rows(size(mdl%mass_s)), cols(size(mdl%mass_s)))
        grp = 0
        grp(first) = [(g, g = 1, ng)]
        do g = 1, ng
            do k = row_ptr(g), row_ptr(g + 1) - 1
                rows(k) = g
                cols(k) = grp(col1(k))
            end do
        end do
        call csc_from_coo(ng, rows, cols, mdl%mass_s, s, stat, errmsg)
    end subroutine model_scalar_mass

    !> Node-block copy of K_theta and M, built once: 2x2 blocks in 2D, 3x3 in 3D (the
    !> free dofs of a node are consecutive), and the scalars of M's blocks when each is m I.
    pure subroutine block_copy(mdl, st, m)
        type(model_t), intent(inout) :: mdl          !! model being built
        integer, intent(out) :: st                   !! status
        character(len=*), intent(inout) :: m         !! message
        integer, allocatable :: first(:)
        integer :: i, ng
        st = STAT_OK
        if ((mdl%dim /= 2 .and. mdl%dim /= 3) .or. mdl%n_dofs == 0) return
        allocate (first(mdl%msh%n_nodes + 1))
        ng = 0
        do i = 1, mdl%msh%n_nodes
            if (any(mdl%dof(:, i) > 0)) then
                ng = ng + 1
                first(ng) = minval(mdl%dof(:, i), mask=mdl%dof(:, i) > 0)
            end if
        end do
        first(ng + 1) = mdl%n_dofs + 1
        if (mdl%dim == 3) then
            call csc_swap_values(mdl%stiff, mdl%stiff_theta_val)   ! mdl%stiff reads as K_theta
            call block3_from_csc(mdl%stiff, first(1:ng + 1), mdl%stiff_theta_b3, st, m)
            call csc_swap_values(mdl%stiff, mdl%stiff_theta_val)
            call csc_swap_values(mdl%stiff, mdl%mass_val)          ! as M
            if (st == STAT_OK) call block3_from_csc(mdl%stiff, first(1:ng + 1), mdl%mass_b3, st, m)
            call csc_swap_values(mdl%stiff, mdl%mass_val)
            mdl%blocked = st == STAT_OK
            if (mdl%blocked) call block3_scalar_blocks(mdl%mass_b3, mdl%mass_s, mdl%mass_scalar)
            ! M's blocks are mass_s(k) I on K_theta's block pattern: their copy goes
            if (mdl%mass_scalar) then
                mdl%mass_scalar = same_pattern(mdl%mass_b3%row_ptr, mdl%mass_b3%col1, &
                                               mdl%stiff_theta_b3%row_ptr, mdl%stiff_theta_b3%col1)
                if (mdl%mass_scalar) mdl%mass_b3 = block3_t()
            end if
            return
        end if
        call csc_swap_values(mdl%stiff, mdl%stiff_theta_val)
        call block2_from_csc(mdl%stiff, first(1:ng + 1), mdl%stiff_theta_b, st, m)
        call csc_swap_values(mdl%stiff, mdl%stiff_theta_val)
        call csc_swap_values(mdl%stiff, mdl%mass_val)
        if (st == STAT_OK) call block2_from_csc(mdl%stiff, first(1:ng + 1), mdl%mass_b, st, m)
        call csc_swap_values(mdl%stiff, mdl%mass_val)
        mdl%blocked = st == STAT_OK
        if (mdl%blocked) call block2_scalar_blocks(mdl%mass_b, mdl%mass_s, mdl%mass_scalar)
        if (mdl%mass_scalar) then
            mdl%mass_scalar = same_pattern(mdl%mass_b%row_ptr, mdl%mass_b%col1, &
                                           mdl%stiff_theta_b%row_ptr, mdl%stiff_theta_b%col1)
            if (mdl%mass_scalar) mdl%mass_b = block2_t()
        end if

    contains

        !> Two block patterns (row ranges, column groups) are the same (M and K_theta
        !> share their CSC pattern, so theirs are).
        pure logical function same_pattern(rp1, c1, rp2, c2)
            integer, intent(in) :: rp1(:), c1(:), rp2(:), c2(:)   !! the two patterns
            same_pattern = size(rp1) == size(rp2) .and. size(c1) == size(c2)
            if (same_pattern) same_pattern = all(rp1 == rp2) .and. all(c1 == c2)
        end function same_pattern
    end subroutine block_copy

    !> Snap the probe to the nearest point of Gamma_C when it lies within
    !> PROBE_SNAP x the local facet length (a note reports the point used);
    !> farther, an error gives the distance and the nearest point.
    pure subroutine snap_probe(mdl, prm, st, m)
        type(model_t), intent(inout) :: mdl          !! model being built
        type(model_params_t), intent(in) :: prm      !! parameters
        integer, intent(out) :: st                   !! status
        character(len=*), intent(inout) :: m         !! message
        real(dp), parameter :: PROBE_SNAP = 0.5_dp   ! tolerance / facet length
        real(dp), parameter :: EXACT = 1.0e-9_dp      ! relative distance counted as "on Gamma_C"
        real(dp) :: p(mdl%dim), q(mdl%dim), best(mdl%dim), xa(mdl%dim), xb(mdl%dim), t, d, dbest, hbest
        real(dp) :: ta(3), tb(3), tc(3), w(3)
        integer :: f, dim
        character(len=160) :: buf
        character(len=40) :: vfmt
        st = STAT_OK
        dim = mdl%dim
        p = prm%probe(1:dim)
        dbest = huge(1.0_dp); hbest = 1.0_dp; best = p
        do f = 1, mdl%ct%n_facets
            xa = mdl%msh%x(:, mdl%ct%nodes(1, f))
            if (dim == 1) then
                q = xa
                d = abs(p(1) - xa(1))
                t = facet_size(mdl, f)
            else if (dim == 3) then
                call facet_triangle(mdl, f, ta, tb, tc)
                w = triangle_nearest(p, ta, tb, tc)
                q = w(1) * ta + w(2) * tb + w(3) * tc
                d = euclid_length(p - q)
                t = max(euclid_length(tb - ta), euclid_length(tc - tb), &
                        euclid_length(ta - tc))
            else
                xb = mdl%msh%x(:, mdl%ct%nodes(2, f))
                t = dot_product(p - xa, xb - xa) / sum((xb - xa)**2)
                q = xa + min(1.0_dp, max(0.0_dp, t)) * (xb - xa)
                d = euclid_length(p - q)
                t = euclid_length(xb - xa)
            end if
            if (d < dbest) then
                dbest = d; best = q; hbest = t
            end if
        end do
        if (dbest > PROBE_SNAP * hbest) then
            st = STAT_BAD_INPUT
            ! es13.5e3 holds -d.ddddE-ddd (13 characters); single_blanks drops the padding
            write (vfmt, '(a, i0, a)') '(a, es10.3e3, a, ', max(2, dim), '(es13.5e3, 1x))'
            write (buf, vfmt) 'the point is not on the contact boundary: ' &
                //'distance ', dbest, ' to its nearest point ', best
            m = single_blanks(buf)//' (snapped only within '//trim(real_str(PROBE_SNAP))//' x the facet length)'
            ! a mesh of one's own with the probe left out: the default is the built-in bar's
            if (.not. prm%probe_given) m = trim(m)//'; the scene does not give &contact probe, '// &
                'whose default is the middle of the built-in bar''s bottom: give a point of '// &
                'the contact boundary, such as that nearest point'
            return
        end if
        call locate_probe(mdl, best, st)
        if (st /= STAT_OK) then
            m = 'the point is not on the contact boundary'
            return
        end if
        if (dbest > EXACT * hbest) then
            write (vfmt, '(a, i0, a)') '(a, ', dim, '(es13.5e3, 1x), a, es10.3e3, a)'
            write (buf, vfmt) 'note: &contact probe snapped to ', &
                best(1:dim), '(distance ', dbest, ')'
            call note(mdl, single_blanks(buf))
        end if
    end subroutine snap_probe

    !> Length of the owner cell of contact facet f along x (1D facet size).
    pure function facet_size(mdl, f) result(hf)
        type(model_t), intent(in) :: mdl             !! model
        integer, intent(in) :: f                     !! contact facet
        real(dp) :: hf
        hf = maxval(mdl%msh%x(1, mdl%msh%cells(:, mdl%ct%cell(f)))) &
             - minval(mdl%msh%x(1, mdl%msh%cells(:, mdl%ct%cell(f))))
    end function facet_size

    !> Append one line to the model's notes.
    pure subroutine note(mdl, line)
        type(model_t), intent(inout) :: mdl          !! model being built
        character(len=*), intent(in) :: line         !! line to append
        mdl%notes = trim(mdl%notes)//trim(line)//new_line('a')
    end subroutine note

    !> Warn when obstacle_normal points into the body. Rule: a contact facet can face
    !> the obstacle when its outward normal (away from its owner cell) has a positive
    !> component along obstacle_normal; the warning is given when no facet can. A mean
    !> of the cosines would not do: on a closed contact boundary (a disk's whole
    !> outline) it is 0 whatever the normal, and part of the facets always face the
    !> obstacle, so a closed boundary never warns; an open one (the bar's bottom)
    !> warns when all its facets face away from the obstacle or are parallel to it.
    pure subroutine check_normal(mdl, faces)
        type(model_t), intent(inout) :: mdl          !! model being built
        logical, intent(out) :: faces                !! some contact facet faces the obstacle
        real(dp), parameter :: FACING = 1.0e-9_dp   ! cosine counted as facing
        integer :: f, dim
        real(dp) :: xa(mdl%dim), xb(mdl%dim), xc(mdl%dim), nf(mdl%dim), c_max
        real(dp) :: ta(3), tb(3), tc(3)
        character(len=200) :: buf
        character(len=8) :: cbuf
        dim = mdl%dim
        c_max = -huge(1.0_dp)
        do f = 1, mdl%ct%n_facets
            xa = mdl%msh%x(:, mdl%ct%nodes(1, f))
            xc = sum(mdl%msh%x(:, mdl%msh%cells(:, mdl%ct%cell(f))), dim=2) / (dim + 1)
            if (dim == 1) then
                nf = sign(1.0_dp, xa - xc)
            else if (dim == 3) then
                call facet_triangle(mdl, f, ta, tb, tc)
                tb = tb - ta; tc = tc - ta
                nf = [tb(2) * tc(3) - tb(3) * tc(2), tb(3) * tc(1) - tb(1) * tc(3), &
                      tb(1) * tc(2) - tb(2) * tc(1)]
                if (dot_product(nf, ta - xc) < 0.0_dp) nf = -nf
            else
                xb = mdl%msh%x(:, mdl%ct%nodes(2, f))
                nf = [xb(2) - xa(2), xa(1) - xb(1)]
                if (dot_product(nf, 0.5_dp * (xa + xb) - xc) < 0.0_dp) nf = -nf
            end if
            c_max = max(c_max, dot_product(nf, mdl%normal(1:dim)) / euclid_length(nf))
        end do
        faces = .not. (mdl%ct%n_facets > 0 .and. c_max <= FACING)
        if (.not. faces) then
            write (cbuf, '(f6.3)') c_max
            buf = 'warning: &contact obstacle_normal points into the body (no contact facet '// &
                  'faces the obstacle: largest cosine with their outward normals '// &
                  trim(adjustl(cbuf))//'); it should point from the body into the obstacle'
            call note(mdl, trim(buf))
        end if
    end subroutine check_normal

    !> Warn when the contact boundary starts inside the obstacle: an initial gap
    !> g = (obstacle_point - x).n below -GAP_RTOL times the contact boundary's extent at
    !> some contact node (an obstacle_point on the wrong side, or a mesh placed across
    !> the plane). The run then starts with the contact pushing the body out, at once and
    !> hard, which is rarely meant; the node and its gap are named. The tolerance lets
    !> nodes on the plane to round-off (a curved outline touching it) pass.
    pure subroutine check_gap(mdl)
        type(model_t), intent(inout) :: mdl          !! model being built
        real(dp), parameter :: GAP_RTOL = 1.0e-9_dp
        integer :: f, j, jf(2), dim
        integer, allocatable :: ids(:)
        real(dp) :: extent, g_min
        character(len=300) :: buf
        character(len=80) :: vfmt
        dim = mdl%dim
        if (mdl%ct%n_facets == 0) return
        jf = minloc(mdl%ct%gap(1:dim, 1:mdl%ct%n_facets))
        g_min = mdl%ct%gap(jf(1), jf(2))
        ids = reshape(mdl%ct%nodes(1:dim, 1:mdl%ct%n_facets), [dim * mdl%ct%n_facets])
        extent = 0.0_dp
        do j = 1, dim
            extent = max(extent, maxval(mdl%msh%x(j, ids)) - minval(mdl%msh%x(j, ids)))
        end do
        f = jf(2)
        if (g_min >= -GAP_RTOL * max(extent, tiny(1.0_dp))) return
        write (vfmt, '(a, i0, a)') '(a, es11.3e3, a, ', dim, '(es13.5e3, 1x), a)'
        write (buf, vfmt) 'warning: the contact boundary starts inside the obstacle: initial '// &
            'gap ', g_min, ' at the node ', mdl%msh%x(:, mdl%ct%nodes(jf(1), f)), &
            '(check &contact obstacle_point and obstacle_normal: the contact pushes it out '// &
            'at the first step)'
        call note(mdl, single_blanks(buf))
    end subroutine check_gap

    !> gamma0 against the material: with theta = 1, K_theta = K - sum theta |F| /
    !> gamma_N s s^T stays positive semi-definite if on every cell touching Gamma_C
    !> sum_f (|F| / gamma_N) s^T K_e^+ s <= 1 (Cauchy-Schwarz in the K_e norm; s is
    !> orthogonal to the rigid modes). With gamma_N = gamma0 / h_T this is gamma0 >=
    !> gamma0_min = max over cells of sum_f |F| h_T s^T K_e^+ s, a bound of the mesh and
    !> the material alone: it is computed without gamma0, so a gamma0 near the underflow
    !> limit (whose gamma_N = gamma0 / h_T would overflow |F| / gamma_N) still gets the
    !> true bound and a usable suggestion. Below it theta = 1 is an error, theta = 0 / -1
    !> a warning (weakly enforced contact).
    pure subroutine check_gamma0(mdl, prm, lambda, mu, st, m)
        type(model_t), intent(inout) :: mdl          !! model being built
        type(model_params_t), intent(in) :: prm      !! parameters
        real(dp), intent(in) :: lambda, mu           !! Lame parameters
        integer, intent(out) :: st                   !! status
        character(len=*), intent(inout) :: m         !! message
        real(dp), parameter :: SUGGEST = 2.0_dp   ! margin of the suggested value over gamma0_min
        real(dp), parameter :: BOUND_RTOL = 1.0e-12_dp   ! 'at the bound', relative
        real(dp) :: g_min, g_sug, stiff
        real(dp), allocatable :: ratio(:)
        integer :: f, c
        character(len=400) :: buf
        st = STAT_OK
        allocate (ratio(mdl%msh%n_cells))
        ratio = 0.0_dp
        do f = 1, mdl%ct%n_facets
            c = mdl%ct%cell(f)
            ratio(c) = ratio(c) + mdl%ct%measure(f) * facet_compliance(mdl, prm%young, lambda, &
                mu, f) * simplex_diameter(mdl%dim, mdl%msh%x(:, mdl%msh%cells(:, c)))
        end do
        g_min = maxval(ratio)
        mdl%gamma0_min = g_min
        ! at the bound K_theta is singular on a contact cell: with theta = 1 the run
        ! needs gamma0 above it (to round-off). J0 = M + c K_theta stays definite there, but
        ! the dynamics has a mode of zero stiffness (1D, where the bound is exact: the
        ! contact node, which drifts; with the redistributed mass, no inertia either), and
        ! just above the bound a very soft one: a note below SUGGEST x the bound in 1D (in
        ! 2D and 3D the bound is conservative: the seed's and the 3D scenes' gamma0 = 10 is
        ! 1.25-3.5 x it, and runs at 1.0003 x it stay stable)
        stiff = prm%young
        if (mdl%dim >= 2) stiff = lambda + 2.0_dp * mu
        ! the suggestion: twice the element bound, or the stiffness where there is no bound
        ! (the penalty's and the augmented Lagrangian's 0, whose log10 round_up cannot take)
        if (g_min > 0.0_dp) then
            g_sug = round_up(SUGGEST * g_min)
        else
            g_sug = round_up(stiff)
        end if
        if (prm%nitsche_theta == 1 .and. .not. prm%gamma0 > g_min * (1.0_dp + BOUND_RTOL)) then
            st = STAT_BAD_INPUT
            write (buf, '(a, es10.3e3, a, es10.3e3, a, es8.1e3, a, es10.3e3, a)') '', prm%gamma0, &
                ' is too small for the material: with theta = 1, K_theta is indefinite below ' &
                //'gamma0 = ', g_min, ' (element bound) and singular at it; use gamma0 = ', &
                g_sug, ' (the stiffness E or lambda + 2 mu is ', stiff, '; docs/scenes.md)'
            m = trim(adjustl(buf))
        else if (.not. (all(ieee_is_finite(mdl%ct%gamma)) .and. &
                        all(ieee_is_finite(1.0_dp / mdl%ct%gamma)))) then
            ! the contact terms carry gamma_N and |F| / gamma_N: a gamma0 near either end
            ! of the range of reals (1e-320, 1e308) overflows one of them, and the first
            ! step that touches the obstacle is NaN
            st = STAT_BAD_INPUT
            write (buf, '(a, es10.3e3, a, es8.1e3, a)') '', prm%gamma0, ' is out of range: '// &
                'gamma_N = gamma0 / h_T or 1 / gamma_N overflows on this mesh; use gamma0 = ', &
                g_sug, ' (docs/scenes.md)'
            m = trim(adjustl(buf))
        else if (prm%nitsche_theta == 1) then
            if (mdl%dim == 1 .and. prm%gamma0 < SUGGEST * g_min) then
                write (buf, '(a, es10.3e3, a, es10.3e3, a, es8.1e3, a)') &
                    'warning: &contact gamma0 = ', prm%gamma0, ' is less than twice the '// &
                    'element bound ', g_min, ' (theta = 1): the contact cell is left '// &
                    'soft and its slow mode pollutes u_n, v_n and p_n (in 1D the bound '// &
                    'is exact); consider gamma0 = ', g_sug, ' (docs/scenes.md)'
                call note(mdl, trim(buf))
            end if
        else if (prm%gamma0 < g_min) then
            write (buf, '(a, es10.3e3, a, es10.3e3, a, es8.1e3, a)') &
                'warning: &contact gamma0 = ', prm%gamma0, &
                ' is small for the material (contact weakly enforced, large penetration; ' &
                //'theta = 1 would need gamma0 >= ', g_min, '): consider gamma0 = ', g_sug, &
                ' (docs/scenes.md)'
            call note(mdl, trim(buf))
        end if
    end subroutine check_gamma0

    !> s^T K_e^+ s for contact facet f (owner cell stiffness, rigid modes removed).
    pure function facet_compliance(mdl, young, lambda, mu, f) result(c)
        type(model_t), intent(in) :: mdl             !! model
        real(dp), intent(in) :: young                !! E (1D)
        real(dp), intent(in) :: lambda, mu           !! Lame parameters
        integer, intent(in) :: f                     !! contact facet
        real(dp) :: c
        real(dp) :: xe(3, 4), ke(MAX_E, MAX_E), r(MAX_E, 6), x(MAX_E), scale
        integer :: ne, nr, a, b, piv(MAX_E), info, cell, dim
        dim = mdl%dim
        cell = mdl%ct%cell(f)
        ne = mdl%ndof_e
        xe = 0.0_dp
        xe(1:dim, 1:dim + 1) = mdl%msh%x(:, mdl%msh%cells(:, cell))
        call p1_stiffness(dim, xe(1:dim, 1:dim + 1), lambda, mu, young, ke(1:ne, 1:ne))
        ! Rigid modes (translations, rotation about the centroid), orthonormalized.
        r = 0.0_dp
        if (dim == 1) then
            nr = 1
            r(1:2, 1) = 1.0_dp
        else if (dim == 3) then
            nr = 6
            do a = 1, 4
                x(1:3) = xe(:, a) - sum(xe(:, 1:4), dim=2) / 4.0_dp
                do b = 1, 3
                    r(3 * (a - 1) + b, b) = 1.0_dp
                end do
                ! rotations about the axes through the centroid: e_k x (x - x_c)
                r(3 * a - 1, 4) = -x(3); r(3 * a, 4) = x(2)
                r(3 * a - 2, 5) = x(3); r(3 * a, 5) = -x(1)
                r(3 * a - 2, 6) = -x(2); r(3 * a - 1, 6) = x(1)
            end do
        else
            nr = 3
            do a = 1, 3
                r(2 * a - 1, 1) = 1.0_dp
                r(2 * a, 2) = 1.0_dp
                r(2 * a - 1, 3) = -(xe(2, a) - sum(xe(2, 1:3)) / 3.0_dp)
                r(2 * a, 3) = xe(1, a) - sum(xe(1, 1:3)) / 3.0_dp
            end do
        end if
        do a = 1, nr
            do b = 1, a - 1
                r(1:ne, a) = r(1:ne, a) - dot_product(r(1:ne, a), r(1:ne, b)) * r(1:ne, b)
            end do
            r(1:ne, a) = r(1:ne, a) / euclid_length(r(1:ne, a))
        end do
        scale = 0.0_dp
        do a = 1, ne
            scale = scale + ke(a, a)
        end do
        scale = scale / ne
        do b = 1, ne
            do a = 1, ne
                ke(a, b) = ke(a, b) + scale * dot_product(r(a, 1:nr), r(b, 1:nr))
            end do
        end do
        call dense_lu_factor(ne, ke(1:ne, 1:ne), piv(1:ne), info)
        c = huge(1.0_dp)
        if (info /= 0) return
        x(1:ne) = mdl%ct%s(1:ne, f)
        call dense_lu_solve(ne, ke(1:ne, 1:ne), piv(1:ne), x(1:ne))
        c = dot_product(mdl%ct%s(1:ne, f), x(1:ne))
    end function facet_compliance

    !> The smallest of 1, 2, 5 x 10^k that is >= v (v > 0).
    pure function round_up(v) result(r)
        real(dp), intent(in) :: v   !! value (> 0)
        real(dp) :: r
        real(dp), parameter :: STEPS(4) = [1.0_dp, 2.0_dp, 5.0_dp, 10.0_dp]
        real(dp) :: p
        integer :: k
        p = 10.0_dp**floor(log10(v))
        do k = 1, 4
            r = p * STEPS(k)
            if (r >= v * (1.0_dp - 1.0e-12_dp)) return
        end do
    end function round_up

    !> Text t trimmed, with every run of blanks made one blank (numbers written with
    !> room for a sign read as in prose).
    pure function single_blanks(t) result(r)
        character(len=*), intent(in) :: t            !! text
        character(len=:), allocatable :: r
        integer :: k
        r = ''
        do k = 1, len_trim(t)
            if (t(k:k) == ' ' .and. k > 1) then
                if (t(k - 1:k - 1) == ' ') cycle
            end if
            r = r//t(k:k)
        end do
    end function single_blanks

    !> A real as short text.
    pure function real_str(x) result(t)
        real(dp), intent(in) :: x   !! value
        character(len=:), allocatable :: t
        character(len=32) :: b
        write (b, '(g0.3)') x
        t = trim(adjustl(b))
    end function real_str

    !> Facets holding the probe point p (two when it is a shared node).
    pure subroutine locate_probe(mdl, p, st)
        type(model_t), intent(inout) :: mdl          !! model being built
        real(dp), intent(in) :: p(:)                 !! the point (on Gamma_C)
        integer, intent(out) :: st                   !! status
        integer :: f, dim
        real(dp) :: xa(mdl%dim), xb(mdl%dim), t, len2, dist, tol, ta(3), tb(3), tc(3), w(3), nsh(MAX_FN)
        dim = mdl%dim
        st = STAT_OK
        mdl%n_probe = 0
        do f = 1, mdl%ct%n_facets
            if (mdl%n_probe == 2 .and. dim < 3) exit
            xa = mdl%msh%x(:, mdl%ct%nodes(1, f))
            if (dim == 1) then
                ! relative to the point's coordinate and the facet's cell (a bar of any
                ! length: an absolute floor would take both ends of a bar shorter than it)
                tol = 1.0e-9_dp * max(abs(xa(1)), facet_size(mdl, f))
                if (abs(p(1) - xa(1)) <= tol) call add_probe_facet(mdl, f, facet_shape(1, 0.0_dp))
                cycle
            else if (dim == 3) then
                call facet_triangle(mdl, f, ta, tb, tc)
                w = triangle_nearest(p, ta, tb, tc)
                dist = euclid_length(p - w(1) * ta - w(2) * tb - w(3) * tc)
                tol = 1.0e-9_dp * max(euclid_length(tb - ta), euclid_length(tc - tb), &
                                      euclid_length(ta - tc))
                if (dist > tol) cycle
                where (w < 1.0e-9_dp) w = 0.0_dp   ! on an edge or node: exactly there
                nsh = w / sum(w)
                call add_probe_facet(mdl, f, nsh)
                cycle
            end if
            xb = mdl%msh%x(:, mdl%ct%nodes(2, f))
            len2 = sum((xb - xa)**2)
            t = dot_product(p - xa, xb - xa) / len2
            dist = euclid_length(p - xa - t * (xb - xa))
            tol = 1.0e-9_dp * sqrt(len2)
            if (dist > tol .or. t < -1.0e-9_dp .or. t > 1.0_dp + 1.0e-9_dp) cycle
            call add_probe_facet(mdl, f, facet_shape(2, min(1.0_dp, max(0.0_dp, t))))
        end do
        if (mdl%n_probe == 0) st = STAT_BAD_INPUT
    end subroutine locate_probe

    !> Record facet f (its shape values nsh at the probe) as holding the probe.
    pure subroutine add_probe_facet(mdl, f, nsh)
        type(model_t), intent(inout) :: mdl          !! model being built
        integer, intent(in) :: f                     !! contact facet
        real(dp), intent(in) :: nsh(:)               !! (MAX_FN) its shape values at the probe
        if (mdl%n_probe == MAX_PROBE) return
        mdl%n_probe = mdl%n_probe + 1
        mdl%probe_facet(mdl%n_probe) = f
        mdl%probe_shape(:, mdl%n_probe) = nsh
        mdl%probe_node(mdl%n_probe) = 0
        if (count(nsh == 1.0_dp) == 1 .and. count(nsh == 0.0_dp) == size(nsh) - 1) &
            mdl%probe_node(mdl%n_probe) = findloc(nsh, 1.0_dp, dim=1)
    end subroutine add_probe_facet

    !> The point of triangle (a, b, c) nearest to p, as barycentric coordinates
    !> (Ericson, Real-Time Collision Detection, 5.1.5: the Voronoi regions of the
    !> vertices, then of the edges, else the inside).
    pure function triangle_nearest(p, a, b, c) result(w)
        real(dp), intent(in) :: p(3), a(3), b(3), c(3)   !! point, triangle
        real(dp) :: w(3)
        real(dp) :: ab(3), ac(3), ap(3), bp(3), cp(3), d1, d2, d3, d4, d5, d6, va, vb, vc, t, den
        ab = b - a; ac = c - a; ap = p - a
        d1 = dot_product(ab, ap); d2 = dot_product(ac, ap)
        if (d1 <= 0.0_dp .and. d2 <= 0.0_dp) then
            w = [1.0_dp, 0.0_dp, 0.0_dp]; return
        end if
        bp = p - b
        d3 = dot_product(ab, bp); d4 = dot_product(ac, bp)
        if (d3 >= 0.0_dp .and. d4 <= d3) then
            w = [0.0_dp, 1.0_dp, 0.0_dp]; return
        end if
        vc = d1 * d4 - d3 * d2
        if (vc <= 0.0_dp .and. d1 >= 0.0_dp .and. d3 <= 0.0_dp) then
            t = d1 / (d1 - d3)
            w = [1.0_dp - t, t, 0.0_dp]; return
        end if
        cp = p - c
        d5 = dot_product(ab, cp); d6 = dot_product(ac, cp)
        if (d6 >= 0.0_dp .and. d5 <= d6) then
            w = [0.0_dp, 0.0_dp, 1.0_dp]; return
        end if
        vb = d5 * d2 - d1 * d6
        if (vb <= 0.0_dp .and. d2 >= 0.0_dp .and. d6 <= 0.0_dp) then
            t = d2 / (d2 - d6)
            w = [1.0_dp - t, 0.0_dp, t]; return
        end if
        va = d3 * d6 - d5 * d4
        if (va <= 0.0_dp .and. d4 - d3 >= 0.0_dp .and. d5 - d6 >= 0.0_dp) then
            t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            w = [0.0_dp, 1.0_dp - t, t]; return
        end if
        den = 1.0_dp / (va + vb + vc)
        w = [va * den, vb * den, vc * den]
    end function triangle_nearest

    !> Contact facet f of a 3D model: its node coordinates.
    pure subroutine facet_triangle(mdl, f, xa, xb, xc)
        type(model_t), intent(in) :: mdl             !! model
        integer, intent(in) :: f                     !! contact facet
        real(dp), intent(out) :: xa(3), xb(3), xc(3) !! its nodes
        xa = mdl%msh%x(:, mdl%ct%nodes(1, f))
        xb = mdl%msh%x(:, mdl%ct%nodes(2, f))
        xc = mdl%msh%x(:, mdl%ct%nodes(3, f))
    end subroutine facet_triangle

    !> b = B(u) = K_theta u + contact part; ktu = K_theta u; active points and the
    !> contact energy parts and the total normal contact force (see contact_eval).
    pure subroutine model_eval_b(mdl, u, b, ktu, active, e_pen, e_theta, f_n)
        type(model_t), intent(in) :: mdl      !! model
        real(dp), intent(in) :: u(:)          !! free-dof displacement
        real(dp), intent(out) :: b(:)         !! B(u)
        real(dp), intent(out) :: ktu(:)       !! K_theta u
        integer, intent(out) :: active        !! active contact quadrature points
        real(dp), intent(out) :: e_pen        !! int [P]_-^2 / (2 gamma)
        real(dp), intent(out) :: e_theta      !! sum theta |F| sigma_n^2 / (2 gamma)
        real(dp), intent(out), optional :: f_n !! int [P]_- (0 with the augmented Lagrangian)
        real(dp) :: fn
        call model_stiff_apply(mdl, u, ktu)
        b = ktu
        active = 0; e_pen = 0.0_dp; e_theta = 0.0_dp; fn = 0.0_dp
        ! the augmented Lagrangian's contact part -N lambda is the scheme's (it holds lambda)
        if (mdl%has_contact .and. mdl%alm%kind == ALM_OFF) &
            call contact_eval(mdl%ct, u, b, active, e_pen, e_theta, f_n=fn)
        if (present(f_n)) f_n = fn
    end subroutine model_eval_b

    !> jdu = B'(u) du (generalized derivative).
    pure subroutine model_apply_jacobian(mdl, u, du, jdu)
        type(model_t), intent(in) :: mdl      !! model
        real(dp), intent(in) :: u(:)          !! linearization point
        real(dp), intent(in) :: du(:)         !! direction
        real(dp), intent(out) :: jdu(:)       !! B'(u) du
        real(dp), allocatable :: ua(:, :), vb(:, :), rdummy(:)
        integer, allocatable :: qloc(:, :)
        integer :: active, rank, q, i
        real(dp) :: e1, e2, vdu
        call model_stiff_apply(mdl, du, jdu)
        if (.not. mdl%has_contact .or. mdl%alm%kind /= ALM_OFF) return
        allocate (ua(mdl%ndof_e, contact_max_rank(mdl%ct)), vb(mdl%ndof_e, contact_max_rank(mdl%ct)), &
                  qloc(mdl%ndof_e, contact_max_rank(mdl%ct)), rdummy(size(u)))
        rdummy = 0.0_dp
        call contact_eval(mdl%ct, u, rdummy, active, e1, e2, rank, ua, vb, qloc)
        do q = 1, rank
            vdu = 0.0_dp
            do i = 1, mdl%ndof_e
                if (qloc(i, q) > 0) vdu = vdu + vb(i, q) * du(mdl%ct%cdofs(qloc(i, q)))
            end do
            do i = 1, mdl%ndof_e
                if (qloc(i, q) > 0) jdu(mdl%ct%cdofs(qloc(i, q))) = &
                    jdu(mdl%ct%cdofs(qloc(i, q))) + ua(i, q) * vdu
            end do
        end do
    end subroutine model_apply_jacobian

    !> The length over which the 'compressed_bar' lift -amplitude (1 - d/length) n falls
    !> to 0: prm%length, or with prm%length_from_mesh the body's extent along n from the
    !> obstacle plane, the largest d(x) = (obstacle_point - x).n over the mesh's nodes. That
    !> is the body's own length along n where it touches the plane (the seed's bar), so that
    !> the lift is 0 at its far end whatever length a mesh file's body has; a length of
    !> &mesh length's default would strain another body by amplitude/1.0 and lift its far
    !> end. Not > 0 when no node is on the body's side of the plane.
    pure function model_lift_length(mdl, prm) result(length)
        type(model_t), intent(in) :: mdl            !! model (its mesh and normal)
        type(model_params_t), intent(in) :: prm     !! its parameters (obstacle point, length)
        real(dp) :: length                          !! the lift's length (mesh units)
        integer :: node, dim
        if (.not. prm%length_from_mesh) then
            length = prm%length
            return
        end if
        dim = mdl%dim
        length = -huge(1.0_dp)
        do node = 1, mdl%msh%n_nodes
            length = max(length, dot_product(prm%obstacle_point(1:dim) - mdl%msh%x(:, node), &
                                             mdl%normal(1:dim)))
        end do
    end function model_lift_length

    !> Initial displacement and velocity (SPEC section 3, &initial).
    pure subroutine model_initial(mdl, prm, u0, v0)
        type(model_t), intent(in) :: mdl            !! model
        type(model_params_t), intent(in) :: prm     !! its parameters (initial condition)
        real(dp), intent(out) :: u0(:)        !! (n_dofs)
        real(dp), intent(out) :: v0(:)        !! (n_dofs)
        integer :: i, node, k, dim
        real(dp) :: d, length
        dim = mdl%dim
        u0 = 0.0_dp
        v0 = 0.0_dp
        length = prm%length
        if (prm%initial == INITIAL_COMPRESSED_BAR) length = model_lift_length(mdl, prm)
        do i = 1, mdl%n_dofs
            node = mdl%dof_node(i)
            k = mdl%dof_comp(i)
            select case (prm%initial)
            case (INITIAL_VELOCITY)
                v0(i) = prm%velocity(k)
            case (INITIAL_COMPRESSED_BAR)
                d = dot_product(prm%obstacle_point(1:dim) - mdl%msh%x(:, node), mdl%normal(1:dim))
                u0(i) = -prm%amplitude * (1.0_dp - d / length) * mdl%normal(k)
            end select
        end do
    end subroutine model_initial

    !> The initial state's energies are finite. Each key is finite and in its range, yet
    !> a velocity of 1e308, a lift of 1e200 or a Young's modulus whose stiffness entries
    !> overflow would start the run at e_total(0) = Infinity (or NaN) and be reported
    !> as a blow-up at its first step; it is bad input (STAT_BAD_INPUT, the message
    !> names the scene file and the key). In the order a cause propagates: the matrices
    !> (&material young: K; density: M), the load (gravity with density), the kinetic
    !> energy v0.M v0 / 2 (&initial velocity) and the elastic, contact and load terms at
    !> u0 (&initial amplitude, the only key that lifts u0 from 0; at u0 = 0 the contact
    !> energy of a body starting in the obstacle, &contact gamma0). It reads the products
    !> the run evaluates at its initial state anyway (M v0 and B(u0): model_mass_apply,
    !> model_eval_b), which are finite or not whatever the matrices hold: O(n) here.
    pure subroutine model_check_initial(mdl, prm, u0, v0, mv0, ktu0, e_pen, e_theta, &
                                        stat, errmsg)
        type(model_t), intent(in) :: mdl                    !! model
        type(model_params_t), intent(in) :: prm             !! its parameters
        real(dp), intent(in) :: u0(:)                       !! (n_dofs) initial displacement
        real(dp), intent(in) :: v0(:)                       !! (n_dofs) initial velocity
        real(dp), intent(in) :: mv0(:)                      !! M v0
        real(dp), intent(in) :: ktu0(:)                     !! K_theta u0 (model_eval_b)
        real(dp), intent(in) :: e_pen, e_theta              !! contact energies at u0 (model_eval_b)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: dim
        character(len=:), allocatable :: at
        stat = STAT_OK
        dim = mdl%dim
        if (.not. all(ieee_is_finite(mdl%stiff%val))) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &material young: '// &
                       real_text(prm%young)//' overflows the stiffness matrix K on this mesh')
            return
        end if
        if (.not. all(ieee_is_finite(mdl%mass_val))) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &material density: '// &
                       real_text(prm%density)//' overflows the mass matrix M on this mesh')
            return
        end if
        if (.not. all(ieee_is_finite(mdl%load))) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &material gravity: '// &
                       'the load rho g overflows on this mesh (&material density = '// &
                       real_text(prm%density)//')')
            return
        end if
        if (.not. ieee_is_finite(0.5_dp * dot_product(v0, mv0))) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': &initial velocity: '// &
                       'the initial kinetic energy v0.M v0 / 2 is not finite (|velocity| = '// &
                       real_text(norm2(prm%velocity(1:dim)))//', &material density = '// &
                       real_text(prm%density)//')')
            return
        end if
        if (ieee_is_finite(0.5_dp * dot_product(u0, ktu0) + e_theta) .and. &
            ieee_is_finite(e_pen) .and. ieee_is_finite(dot_product(u0, mdl%load))) return
        if (any(u0 /= 0.0_dp)) then
            at = '&initial amplitude: the initial elastic and contact energy of kind = '// &
                 '''compressed_bar'' is not finite (amplitude = '//real_text(prm%amplitude)// &
                 ', &material young = '//real_text(prm%young)//', &contact gamma0 = '// &
                 real_text(prm%gamma0)//')'
        else
            at = '&contact gamma0: the contact energy of the initial state is not finite '// &
                 '(gamma0 = '//real_text(prm%gamma0)//')'
        end if
        call raise(stat, errmsg, STAT_BAD_INPUT, trim(prm%name)//': '//at)
    end subroutine model_check_initial

    !> Probe values: u_n, v_n interpolated; p_n = Nitsche pressure (mean over the
    !> facets when the probe is on a shared node or edge). Zero without contact boundary.
    !> With clear true (contact_clear's at u), a facet's pressure at its node is
    !> [P]_- = +-0 exactly: not formed (adding +-0 to the sum, from +0, changes nothing).
    pure subroutine model_probe(mdl, u, v, un, vn, pn, lam, clear)
        type(model_t), intent(in) :: mdl      !! model
        real(dp), intent(in) :: u(:)          !! displacement
        real(dp), intent(in) :: v(:)          !! velocity
        real(dp), intent(out) :: un           !! u . n at the probe
        real(dp), intent(out) :: vn           !! v . n at the probe
        real(dp), intent(out) :: pn           !! contact pressure (<= 0)
        real(dp), intent(in), optional :: lam(:) !! augmented Lagrangian multipliers (p_n from them)
        logical, intent(in), optional :: clear   !! contact_clear found P finite, >= 0 at u (Nitsche)
        integer :: q, f, ne, nf, j
        real(dp) :: ue(MAX_E), ve(MAX_E), nsh(MAX_FN), nu(MAX_FN), nv(MAX_FN)
        logical :: at_clear_node
        un = 0.0_dp; vn = 0.0_dp; pn = 0.0_dp
        if (mdl%n_probe == 0) return
        ne = mdl%ndof_e
        nf = mdl%ct%nfn
        do q = 1, mdl%n_probe
            at_clear_node = .false.
            if (present(clear) .and. mdl%alm%kind == ALM_OFF) then
                at_clear_node = clear .and. mdl%probe_node(q) > 0
            end if
            if (at_clear_node .and. q > 1) cycle      ! (u_n and v_n come from the first facet)
            f = mdl%probe_facet(q)
            call gather(f, u, ue(1:ne))
            nsh = mdl%probe_shape(:, q)
            if (mdl%alm%kind /= ALM_OFF .and. present(lam)) then
                pn = pn + alm_probe(mdl%alm, mdl%ct, lam, f, nsh)
            else if (.not. at_clear_node) then
                pn = pn + facet_pressure(ne, nf, ue(1:ne), mdl%ct%s(:, f), &
                                         mdl%ct%nvec(:, :, f), mdl%ct%gap(:, f), mdl%ct%gamma(f), nsh)
            end if
            if (q == 1) then
                ! the normal components at the facet's nodes, then their interpolation
                ! (fixed-size locals: no heap in a trace row); v enters only here
                call gather(f, v, ve(1:ne))
                do j = 1, nf
                    nu(j) = dot_product(ue(1:ne), mdl%ct%nvec(1:ne, j, f))
                    nv(j) = dot_product(ve(1:ne), mdl%ct%nvec(1:ne, j, f))
                end do
                un = dot_product(nsh(1:nf), nu(1:nf))
                vn = dot_product(nsh(1:nf), nv(1:nf))
            end if
        end do
        pn = pn / mdl%n_probe

    contains

        !> Owner-cell values of a free-dof vector on contact facet ff (0 if constrained).
        pure subroutine gather(ff, w, we)
            integer, intent(in) :: ff       !! contact facet
            real(dp), intent(in) :: w(:)    !! free-dof vector
            real(dp), intent(out) :: we(:)  !! its owner-cell values
            integer :: i
            do i = 1, size(we)
                we(i) = 0.0_dp
                if (mdl%ct%dofs(i, ff) > 0) we(i) = w(mdl%ct%dofs(i, ff))
            end do
        end subroutine gather
    end subroutine model_probe

    !> K_theta's values on K's pattern (mdl%stiff): its CSC values, or when it is held in
    !> node blocks only, read back from them (the same numbers).
    pure subroutine model_stiff_theta_values(mdl, val)
        type(model_t), intent(in) :: mdl      !! model
        real(dp), intent(out) :: val(:)       !! (mdl%stiff%nnz) values
        if (allocated(mdl%stiff_theta_val)) then
            val = mdl%stiff_theta_val
        else if (mdl%dim == 3) then
            call block3_csc_values(mdl%stiff, mdl%stiff_theta_b3, val)
        else
            call block2_csc_values(mdl%stiff, mdl%stiff_theta_b, val)
        end if
    end subroutine model_stiff_theta_values

    !> y = K_theta x (node blocks in 2D and 3D, gather-form CSC product otherwise).
    pure subroutine model_stiff_apply(mdl, x, y)
        type(model_t), intent(in) :: mdl      !! model
        real(dp), intent(in) :: x(:)          !! vector
        real(dp), intent(out) :: y(:)         !! K_theta x
        if (mdl%blocked .and. mdl%dim == 3) then
            call block3_matvec(mdl%stiff_theta_b3, x, y)
        else if (mdl%blocked) then
            call block2_matvec(mdl%stiff_theta_b, x, y)
        else
            call csc_matvec_t_values(mdl%stiff, mdl%stiff_theta_val, x, y)   ! symmetric: A^T x = A x
        end if
    end subroutine model_stiff_apply

    !> y = M x (by 3x3 node blocks in 3D when M has its block copy, the gather-form CSC
    !> product otherwise: the same numbers).
    pure subroutine model_mass_apply(mdl, x, y)
        type(model_t), intent(in) :: mdl      !! model
        real(dp), intent(in) :: x(:)          !! vector
        real(dp), intent(out) :: y(:)         !! M x
        if (mdl%lumped) then
            y = mdl%mass_diag * x
        else if (mdl%blocked .and. mdl%dim == 3 .and. .not. mdl%mass_scalar) then
            call block3_matvec(mdl%mass_b3, x, y)
        else
            call csc_matvec_t_values(mdl%stiff, mdl%mass_val, x, y)   ! symmetric
        end if
    end subroutine model_mass_apply

    !> The products a step ends with, formed from the vectors (never carried):
    !> kx = K_theta x, mv = M v, md = M d; one pass over the shared node blocks in 2D and 3D,
    !> which also stores K_theta x in bx (the caller's B(x) before its contact part: a
    !> second store a row instead of a copy pass).
    pure subroutine model_step_products(mdl, x, v, d, kx, mv, md, bx)
        type(model_t), intent(in) :: mdl      !! model
        real(dp), intent(in) :: x(:)          !! displacement
        real(dp), intent(in) :: v(:)          !! velocity
        real(dp), intent(in) :: d(:)          !! a second vector for M (the next predictor's u - u~)
        real(dp), intent(out) :: kx(:)        !! K_theta x
        real(dp), intent(out) :: mv(:)        !! M v
        real(dp), intent(out) :: md(:)        !! M d
        real(dp), intent(out) :: bx(:)        !! K_theta x again (the caller adds C(x): B(x))
        if (mdl%lumped) then
            call model_stiff_apply(mdl, x, kx)
            mv = mdl%mass_diag * v
            md = mdl%mass_diag * d
        else if (mdl%mass_scalar .and. mdl%dim == 3) then
            call block3_matvec_ks3(mdl%stiff_theta_b3, mdl%mass_s, x, v, d, kx, mv, md, bx)
            return
        else if (mdl%mass_scalar) then
            call block2_matvec_ks3(mdl%stiff_theta_b, mdl%mass_s, x, v, d, kx, mv, md, bx)
            return
        else if (mdl%blocked .and. mdl%dim == 3) then
            call block3_matvec_km(mdl%stiff_theta_b3, mdl%mass_b3, x, v, d, kx, mv, md)
        else if (mdl%blocked) then
            call block2_matvec_km(mdl%stiff_theta_b, mdl%mass_b, x, v, d, kx, mv, md)
        else
            call csc_matvec_t_values(mdl%stiff, mdl%stiff_theta_val, x, kx)
            call csc_matvec_t_values(mdl%stiff, mdl%mass_val, v, mv)
            call csc_matvec_t_values(mdl%stiff, mdl%mass_val, d, md)
        end if
        bx = kx
    end subroutine model_step_products

    !> kx = K_theta x and mv = M v, in one pass over the node blocks when M's blocks are
    !> scalar (the predictor-correctors end their step with these two).
    pure subroutine model_stiff_mass_apply(mdl, x, v, kx, mv)
        type(model_t), intent(in) :: mdl      !! model
        real(dp), intent(in) :: x(:)          !! displacement
        real(dp), intent(in) :: v(:)          !! velocity
        real(dp), intent(out) :: kx(:)        !! K_theta x
        real(dp), intent(out) :: mv(:)        !! M v
        if (mdl%mass_scalar .and. .not. mdl%lumped .and. mdl%dim == 3) then
            call block3_matvec_ks2(mdl%stiff_theta_b3, mdl%mass_s, x, v, kx, mv)
        else if (mdl%mass_scalar .and. .not. mdl%lumped) then
            call block2_matvec_ks2(mdl%stiff_theta_b, mdl%mass_s, x, v, kx, mv)
        else
            call model_stiff_apply(mdl, x, kx)
            call model_mass_apply(mdl, v, mv)
        end if
    end subroutine model_stiff_mass_apply

    !> Expand a free-dof vector to (dim, n_nodes) with zeros on constrained dofs.
    pure subroutine model_full_field(mdl, w, full)
        type(model_t), intent(in) :: mdl      !! model
        real(dp), intent(in) :: w(:)          !! free-dof vector
        real(dp), intent(out) :: full(:, :)   !! (dim, n_nodes)
        integer :: i, k
        do i = 1, mdl%msh%n_nodes
            do k = 1, mdl%dim
                full(k, i) = 0.0_dp
                if (mdl%dof(k, i) > 0) full(k, i) = w(mdl%dof(k, i))
            end do
        end do
    end subroutine model_full_field
end module model
