//! ARM semihosting: the only way this firmware talks to the debugger or emulator, to report its
//! exit status.

/// `SYS_EXIT_EXTENDED`: exit with a full 32-bit status. Plain `SYS_EXIT` on AArch32 can only say
/// "application exit" (0) or something else (1).
const SYS_EXIT_EXTENDED: u32 = 0x20;
/// `ADP_Stopped_ApplicationExit`: the reason code for a normal exit; the status is the subcode.
const ADP_STOPPED_APPLICATION_EXIT: u32 = 0x2_0026;

/// Ends the program with `status` (QEMU exits with it). Without a semihosting host the `svc` traps
/// and the default handler exits again; without any, the core sleeps.
pub fn exit(status: u32) -> ! {
    let block = [ADP_STOPPED_APPLICATION_EXIT, status];
    // SAFETY: the semihosting call reads the two words of `block`, which live until it returns,
    // and writes only r0. `svc 0x123456` is the A32 semihosting trap.
    unsafe {
        core::arch::asm!(
            "svc 0x123456",
            inout("r0") SYS_EXIT_EXTENDED => _,
            in("r1") block.as_ptr(),
            options(nostack, readonly),
        );
    }
    loop {
        // SAFETY: `wfe` only waits for an event.
        unsafe { core::arch::asm!("wfe", options(nomem, nostack)) };
    }
}
