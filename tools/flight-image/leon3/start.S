/* Start-up of the estimator's flight host on a SPARC V8 LEON3 (QEMU leon3_generic;
   src/leon3.rs): the trap table, the register-window overflow and underflow traps, the
   processor state (supervisor, FPU on, interrupts masked), the stack and the BSS; then
   taiji_flight_main. Also the few helpers Rust calls: the stack pointer, a counted
   loop and the exit. Assembled and linked by tools/flight-qemu with
   sparc64-linux-gnu-gcc -m32 -mcpu=leon3 (link.ld). */

#define NWINDOWS 8              /* the LEON3's (and the BM3803's) register windows */
#define PSR_ET   0x20           /* traps enabled */
/* Supervisor (S, PS), all interrupts masked (PIL 15), FPU enabled (EF), window 0. */
#define PSR_INIT (0x1000 | 0xF00 | 0x80 | 0x40)
#define FRAME    96             /* minimum frame: window save area, hidden and six args */

/* A trap table entry: four instructions that jump to the handler, with %psr in %l0
   (the trap itself leaves the trapped PC in %l1 and nPC in %l2). */
#define TRAP(handler) \
        rd      %psr, %l0; \
        sethi   %hi(handler), %l4; \
        jmp     %l4 + %lo(handler); \
        nop

        .section .text.traps, "ax"
        .align  4096
        .global _trap_table
_trap_table:
        TRAP(_start)                    /* 0x00 reset */
        .rept   4                       /* 0x01 - 0x04 */
        TRAP(bad_trap)
        .endr
        TRAP(window_overflow)           /* 0x05 */
        TRAP(window_underflow)          /* 0x06 */
        .rept   256 - 7                 /* 0x07 - 0xff: faults, interrupts, ticc */
        TRAP(bad_trap)
        .endr

        .text
        .global _start
_start:
        set     PSR_INIT, %g1           /* traps stay off until the stack is set */
        wr      %g1, %psr
        nop; nop; nop
        mov     2, %g1                  /* window 1 invalid: window 0 has no caller */
        wr      %g1, %wim
        nop; nop; nop
        set     _trap_table, %g1
        wr      %g1, %tbr
        nop; nop; nop
        set     _stack_top - FRAME, %sp
        mov     %g0, %fp
        /* The BSS is zero (link.ld aligns it to 8 bytes). */
        set     __bss_start, %g2
        set     __bss_end, %g3
1:      cmp     %g2, %g3
        bgeu    2f
        nop
        st      %g0, [%g2]
        ba      1b
        add     %g2, 4, %g2
2:      /* FSR: round to nearest, no floating-point trap enabled. */
        st      %g0, [%sp + 64]
        ld      [%sp + 64], %fsr
        nop
        rd      %psr, %g1
        or      %g1, PSR_ET, %g1
        wr      %g1, %psr
        nop; nop; nop
        call    taiji_flight_main
        nop
        /* taiji_flight_main does not return; should it, the program ends. */

/* Ends the program: a trap with traps disabled puts a SPARC in error mode; QEMU's
   LEON3 takes `ta 0` that way as a shutdown request. */
        .global taiji_leon3_exit
taiji_leon3_exit:
        rd      %psr, %o0
        andn    %o0, PSR_ET, %o0
        wr      %o0, %psr
        nop; nop; nop
        ta      0
3:      ba      3b
        nop

/* The caller's stack pointer (a leaf: no window of its own). */
        .global taiji_leon3_sp
taiji_leon3_sp:
        retl
        mov     %sp, %o0

/* %o0 rounds of exactly three instructions (subcc, bne, the delay slot's nop). */
        .global taiji_leon3_spin
taiji_leon3_spin:
4:      subcc   %o0, 1, %o0
        bne     4b
        nop
        retl
        nop

/* Window overflow: a `save` found the next window invalid. The trap window is that
   invalid window; the one after it holds the oldest frame in the registers: store its
   locals and ins in its own frame's save area, mark it invalid instead, and retry. */
window_overflow:
        mov     %wim, %l3
        mov     %g1, %l7                /* %g1 is the caller's: keep it */
        srl     %l3, 1, %g1             /* WIM rotated right by one */
        sll     %l3, NWINDOWS - 1, %l4
        or      %l4, %g1, %g1
        save                            /* into the window to store */
        mov     %g1, %wim
        nop; nop; nop
        std     %l0, [%sp + 0]
        std     %l2, [%sp + 8]
        std     %l4, [%sp + 16]
        std     %l6, [%sp + 24]
        std     %i0, [%sp + 32]
        std     %i2, [%sp + 40]
        std     %i4, [%sp + 48]
        std     %i6, [%sp + 56]
        restore                         /* back to the trap window */
        mov     %l7, %g1
        jmp     %l1                     /* the `save` again */
        rett    %l2

/* Window underflow: a `restore` found the previous window invalid. Mark the one
   beyond it invalid instead, load the previous window from its frame's save area, and
   retry. */
window_underflow:
        mov     %wim, %l3
        sll     %l3, 1, %l4             /* WIM rotated left by one */
        srl     %l3, NWINDOWS - 1, %l5
        or      %l5, %l4, %l5
        mov     %l5, %wim
        nop; nop; nop
        restore                         /* the window that trapped */
        restore                         /* the window to load */
        ldd     [%sp + 0], %l0
        ldd     [%sp + 8], %l2
        ldd     [%sp + 16], %l4
        ldd     [%sp + 24], %l6
        ldd     [%sp + 32], %i0
        ldd     [%sp + 40], %i2
        ldd     [%sp + 48], %i4
        ldd     [%sp + 56], %i6
        save
        save                            /* back to the trap window */
        jmp     %l1                     /* the `restore` again */
        rett    %l2

/* Any other trap is a fault here: report its type and PC from a fresh context (the
   top of the stack, the current window the only valid one, traps on again); the
   report ends the program. */
bad_trap:
        rd      %tbr, %o0
        srl     %o0, 4, %o0
        and     %o0, 0xff, %o0          /* tt */
        mov     %l1, %o1                /* the trapped PC */
        and     %l0, 0x1f, %l5          /* CWP */
        add     %l5, 1, %l5
        cmp     %l5, NWINDOWS
        bne     5f
        nop
        mov     0, %l5
5:      mov     1, %l6
        sll     %l6, %l5, %l6
        wr      %l6, %wim               /* the window above this one invalid */
        nop; nop; nop
        set     _stack_top - FRAME, %sp
        mov     %g0, %fp
        or      %l0, PSR_ET, %l0
        wr      %l0, %psr
        nop; nop; nop
        call    taiji_leon3_trap
        nop

        .section .note.GNU-stack, "", @progbits
