!> The counts of a msh 4 file's $Nodes and $Elements sections checked against their
!> blocks before gmsh reads the file.
!>
!> Each section opens with a header that gives the number of blocks and the number of
!> nodes (elements) in all blocks; each block gives its own count. gmsh 4.15 sizes its
!> arrays from the header and fills them from the blocks, so a header whose count is
!> smaller than its blocks' sum (a hand edit, counts swapped, a merge of two files)
!> makes gmsh write past the end of its arrays: the process aborts with "corrupted size
!> vs. prev_size" or "double free" and a backtrace, or runs on with a corrupted heap.
!> Here each block is walked (ASCII: its lines; binary: its bytes) and the sum compared
!> with the header's count; a block that does not parse where the header says one is, or
!> a sum that differs, is refused naming the section.
!>
!> Layouts (gmsh's MSH 4.1 reference): ASCII $Nodes: 'numEntityBlocks numNodes minTag
!> maxTag', then per block 'entityDim entityTag parametric numNodesInBlock', that many
!> tag lines and that many coordinate lines; $Elements: 'numEntityBlocks numElements
!> minTag maxTag', then per block 'entityDim entityTag elementType numElementsInBlock' and
!> that many lines. Binary 4.1
!> (data size 8): the header's four size_t, per block three int and a size_t count, then
!> the block's size_t tags and doubles (nodes) or size_t rows of 1 + nodes-per-element
!> (elements). ASCII MSH 4.0, whose counts gmsh trusts the same way ("double free or
!> corruption" on a header count below its blocks'), has two-number headers and one
!> line a node ('tag x y z' after the block's 'entityTag entityDim parametric
!> numNodes'). A file that ends inside a section, a binary file of another layout
!> (MSH 4.0 and 2.2, a data size other than 8, other byte order) or an element type not
!> in the table below are left to gmsh, which refuses them itself or reads them safely.
!> Binary MSH 4.0 needs no check of its own: gmsh 4.15 neither writes nor reads it; it
!> refuses the file on its $MeshFormat line ("Can only read MSH 4.0 format in ASCII
!> mode"), before it sizes any array from a section's header (tests/test_mesh_forms.py,
!> with a header count below its blocks', no invalid access under valgrind).
!> Left to gmsh as well, as it reads them to the same mesh with no invalid access under
!> valgrind (gmsh 4.15, tests/test_mesh_forms.py): a 4.1 $Nodes header whose [minTag,
!> maxTag] does not hold the blocks' tags (1 2, 62 63 or 1 100000000 for tags 1..63), an
!> ASCII file whose $MeshFormat gives data size 4 (ASCII does not use it), and a
!> $PhysicalNames name without its closing quote (gmsh takes the name to the line's end).
module msh_sections
    use, intrinsic :: iso_fortran_env, only: int32, int64
    use errors, only: STAT_OK, STAT_BAD_INPUT, raise
    use os_files, only: read_whole_file
    use text, only: int_text
    implicit none
    private
    public :: msh_check_counts

    character(len=1), parameter :: LF = achar(10), CR = achar(13)

    !> Outcome of walking one section.
    integer, parameter :: WALK_OK = 0, WALK_BAD = 1, WALK_UNKNOWN = 2

contains

    !> Refuse a msh 4 file whose $Nodes or $Elements header count differs from the sum
    !> of its blocks' counts (stat STAT_BAD_INPUT, errmsg 'path: ...'); any other file,
    !> or one that cannot be read here, passes (gmsh reads and judges it).
    subroutine msh_check_counts(path, stat, errmsg)
        character(len=*), intent(in) :: path                 !! the .msh file
        integer, intent(out) :: stat                         !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg  !! why, naming path
        character(len=:), allocatable :: buf
        character(len=64) :: why
        integer(int64) :: nbytes, p
        integer :: ios, file_type, data_size, w
        real :: version
        logical :: binary, ok, v40

        stat = STAT_OK
        call read_whole_file(path, 16, buf, ok)
        if (.not. ok) return
        nbytes = len(buf, int64)
        if (buf(1:11) /= '$MeshFormat') return
        p = 12
        call skip_eol(buf, p)
        read (buf(p:min(nbytes, p + 63)), *, iostat=ios) version, file_type, data_size
        if (ios /= 0 .or. version < 3.95) return          ! 2.2: gmsh's
        binary = file_type == 1
        v40 = version < 4.05
        if (v40 .and. binary) return                       ! binary 4.0: gmsh refuses it
        if (binary) then
            if (data_size /= 8) return
            call next_line(buf, p)
            if (p + 3 > nbytes) return
            if (transfer(buf(p:p + 3), 0_int32) /= 1) return    ! another byte order
        end if

        w = walk(buf, '$Nodes', .true., binary, v40, why)
        if (w == WALK_BAD) then
            call raise(stat, errmsg, STAT_BAD_INPUT, path//': its $Nodes section '//trim(why)// &
                       ' (a header count that differs from its blocks: not read)')
            return
        end if
        w = walk(buf, '$Elements', .false., binary, v40, why)
        if (w == WALK_BAD) then
            call raise(stat, errmsg, STAT_BAD_INPUT, path//': its $Elements section '// &
                       trim(why)//' (a header count that differs from its blocks: not read)')
        end if
    end subroutine msh_check_counts

    !> Walk the section that starts with the line `mark`: WALK_OK when its blocks add up
    !> to its header's count, WALK_BAD with why, WALK_UNKNOWN when it cannot be told.
    integer function walk(buf, mark, nodes, binary, v40, why) result(w)
        character(len=*), intent(in) :: buf        !! the whole file
        character(len=*), intent(in) :: mark       !! '$Nodes' or '$Elements'
        logical, intent(in) :: nodes               !! the section holds nodes
        logical, intent(in) :: binary              !! binary 4.1 layout
        logical, intent(in) :: v40                 !! ASCII 4.0 layout (a node a line)
        character(len=*), intent(out) :: why       !! what does not add up
        integer(int64) :: p, n_blocks, n_total, sum_n, n, b, head(4), fin
        integer(int32) :: ints(3)
        integer :: ios, per

        w = WALK_UNKNOWN
        why = ''
        fin = 0
        p = section_start(buf, mark)
        if (p == 0) return
        if (binary) then
            ! the blocks end at the line '$End...': no such line, a truncated file (gmsh's)
            fin = index(buf(p:), LF//'$End'//mark(2:), kind=int64)
            if (fin == 0 .or. p + 31 > len(buf, int64)) return
            fin = p + fin - 1
            n_blocks = transfer(buf(p:p + 7), 0_int64)
            n_total = transfer(buf(p + 8:p + 15), 0_int64)
            p = p + 32
        else
            read (buf(p:line_end(buf, p)), *, iostat=ios) n_blocks, n_total
            if (ios /= 0) then
                w = WALK_BAD
                why = 'header does not parse'
                return
            end if
            call next_line(buf, p)
        end if
        if (n_blocks < 0 .or. n_total < 0) then
            w = WALK_BAD
            why = 'header has a negative count'
            return
        end if
        sum_n = 0
        do b = 1, n_blocks
            if (p > len(buf, int64)) return                      ! ends inside: gmsh's
            if (binary) then
                if (p + 19 > fin) then
                    w = WALK_BAD
                    why = 'header gives '//int_text(n_blocks)//' blocks, it has fewer'
                    return
                end if
                ints = transfer(buf(p:p + 11), ints)
                n = transfer(buf(p + 12:p + 19), 0_int64)
                p = p + 20
                if (n < 0 .or. n > len(buf, int64)) then
                    w = WALK_BAD
                    why = 'block '//int_text(b)//' has a count '// &
                          'larger than the file'
                    return
                end if
                if (nodes) then
                    per = 3
                    if (ints(3) /= 0) per = 3 + max(0, ints(1))
                    p = p + 8*n + 8*n*per
                else
                    per = nodes_per_element(int(ints(3)))
                    if (per <= 0) return                          ! unknown type: gmsh's
                    p = p + 8*n*(1 + per)
                end if
                if (p > fin) then
                    w = WALK_BAD
                    why = 'block '//int_text(b)//' runs past the end of the section'
                    return
                end if
            else
                if (buf(p:p) == '$') then
                    w = WALK_BAD
                    why = 'header gives '//int_text(n_blocks)// &
                          ' blocks, it has '//int_text(b - 1)
                    return
                end if
                read (buf(p:line_end(buf, p)), *, iostat=ios) head
                if (v40 .and. ios /= 0) return       ! another layout labelled 4.0: gmsh's
                if (ios /= 0 .or. head(4) < 0) then
                    w = WALK_BAD
                    why = 'block '//int_text(b)// &
                          "'s header does not parse"
                    return
                end if
                n = head(4)
                call next_line(buf, p)
                if (nodes .and. .not. v40) then ! the tags' lines, then the coordinates'
                    call skip_lines(buf, p, 2*n)
                else
                    call skip_lines(buf, p, n)
                end if
            end if
            sum_n = sum_n + n
        end do
        if (p > len(buf, int64)) return
        if (sum_n /= n_total) then
            w = WALK_BAD
            why = 'header gives '//int_text(n_total)// &
                  ', its blocks hold '//int_text(sum_n)
            return
        end if
        if (.not. binary) then
            if (buf(p:min(len(buf, int64), p + len(mark) + 2)) /= '$End'//mark(2:)) then
                if (v40) return                      ! another layout labelled 4.0: gmsh's
                w = WALK_BAD
                why = 'has more blocks than its header gives'
                return
            end if
        end if
        w = WALK_OK
    end function walk

    !> Position of the first byte after the line `mark` (at a line start), 0 if none.
    integer(int64) function section_start(buf, mark) result(p)
        character(len=*), intent(in) :: buf   !! the whole file
        character(len=*), intent(in) :: mark  !! section name with its '$'
        integer(int64) :: i, from
        p = 0
        from = 1
        do
            i = index(buf(from:), LF//mark)
            if (i == 0) return
            i = from + i + len(mark)
            if (i <= len(buf, int64)) then
                if (buf(i:i) == LF .or. buf(i:i) == CR) then
                    p = i
                    call skip_eol(buf, p)
                    return
                end if
            end if
            from = i
        end do
    end function section_start

    !> Last position of the line that starts at p (before its LF or CR LF).
    pure integer(int64) function line_end(buf, p) result(e)
        character(len=*), intent(in) :: buf  !! the whole file
        integer(int64), intent(in) :: p      !! a line start
        integer(int64) :: i
        i = index(buf(p:), LF)
        if (i == 0) then
            e = len(buf, int64)
        else
            e = p + i - 2
        end if
        if (e >= p) then
            if (buf(e:e) == CR) e = e - 1
        end if
    end function line_end

    !> Move p to the start of the next line (past the end of buf if none).
    pure subroutine next_line(buf, p)
        character(len=*), intent(in) :: buf   !! the whole file
        integer(int64), intent(inout) :: p    !! position in a line
        integer(int64) :: i
        i = index(buf(p:), LF)
        if (i == 0) then
            p = len(buf, int64) + 1
        else
            p = p + i
        end if
    end subroutine next_line

    !> Move p over n lines.
    pure subroutine skip_lines(buf, p, n)
        character(len=*), intent(in) :: buf   !! the whole file
        integer(int64), intent(inout) :: p    !! a line start
        integer(int64), intent(in) :: n       !! lines to skip
        integer(int64) :: k
        do k = 1, n
            if (p > len(buf, int64)) return
            call next_line(buf, p)
        end do
    end subroutine skip_lines

    !> Move p past an end of line (LF or CR LF) at p, if there is one.
    pure subroutine skip_eol(buf, p)
        character(len=*), intent(in) :: buf   !! the whole file
        integer(int64), intent(inout) :: p    !! position
        if (p <= len(buf, int64)) then
            if (buf(p:p) == CR) p = p + 1
        end if
        if (p <= len(buf, int64)) then
            if (buf(p:p) == LF) p = p + 1
        end if
    end subroutine skip_eol

    !> Nodes of gmsh element type t (the linear and Lagrange types gmsh writes), 0 if
    !> not in this table.
    pure integer function nodes_per_element(t) result(n)
        integer, intent(in) :: t  !! gmsh element type
        integer, parameter :: TABLE(31) = [2, 3, 4, 4, 8, 6, 5, 3, 6, 9, 10, 27, 18, 14, 1, &
                                           8, 20, 15, 13, 9, 10, 12, 15, 15, 21, 4, 5, 6, &
                                           20, 35, 56]
        n = 0
        if (t >= 1 .and. t <= size(TABLE)) n = TABLE(t)
    end function nodes_per_element

end module msh_sections
