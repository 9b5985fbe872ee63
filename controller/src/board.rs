//! The 100 Hz cycle as every board runs it — the STM32H743 drive controller, the QEMU
//! board and the host's run of the firmware on the virtual bus — written once, behind
//! the one trait a board implements ([`CanPort`]).

use crate::correction::AxesCorrection;
use crate::feedforward::{Feedforward, Replan};
use crate::frame::CanFrame;
use crate::planner::Crane;
use crate::{Controller, Cycle};

/// What the cycle needs from a CAN controller: the board's own small trait, because the
/// STM32H743's `fdcan` driver has no embedded-can implementation and neither the QEMU
/// board nor the host has a CAN controller at all (their port is the virtual bus).
pub trait CanPort {
    /// Why a frame will never leave.
    type TxError;

    /// Queues a frame of the cycle at `now_ms` behind those queued before it
    /// (`controller::transmit`: frames leave in this order). `Err`: this frame is
    /// refused and lost — report it.
    fn transmit(&mut self, now_ms: u64, frame: &CanFrame) -> Result<(), Self::TxError>;

    /// The next frame that was queued but will never leave, oldest first, with why:
    /// refused by the bus, or of a cycle before `now_ms` and still waiting (it is taken
    /// back rather than sent stale). Each lost frame is returned once — report it.
    fn lost(&mut self, now_ms: u64) -> Option<(CanFrame, Self::TxError)>;

    /// The next frame received up to `now_ms`, if any.
    fn receive(&mut self, now_ms: u64) -> Option<CanFrame>;
}

/// One cycle at `now_ms`: the frames lost since the last cycle reported (each as
/// itself, before the tick), every frame received handed to the controller, `tick`
/// (the board's, given the port: it injects the scenario's faults, measures the cost
/// and calls [`Controller::tick`]; `None` means the board hangs here and nothing is
/// sent), the
/// burst transmitted in order, and what the bus refused reported at once. `on_lost`
/// sees every lost frame too (the boards log it).
pub fn cycle<F, C, K, P, const A: usize>(
    controller: &mut Controller<F, C, K, A>,
    port: &mut P,
    now_ms: u64,
    tick: impl FnOnce(&mut Controller<F, C, K, A>, &mut P) -> Option<Cycle<A>>,
    mut on_lost: impl FnMut(&CanFrame, &P::TxError),
) -> Option<Cycle<A>>
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: Crane<A>,
    P: CanPort,
{
    report_lost(controller, port, now_ms, &mut on_lost);
    while let Some(frame) = port.receive(now_ms) {
        controller.on_frame(&frame, now_ms);
    }
    let out = tick(controller, port)?;
    for frame in &out.frames {
        if let Err(e) = port.transmit(now_ms, frame) {
            on_lost(frame, &e);
            controller.transmit_failed(frame);
        }
    }
    report_lost(controller, port, now_ms, &mut on_lost);
    Some(out)
}

/// Every frame the port lost since the last call, reported as itself.
fn report_lost<F, C, K, P, const A: usize>(
    controller: &mut Controller<F, C, K, A>,
    port: &mut P,
    now_ms: u64,
    on_lost: &mut impl FnMut(&CanFrame, &P::TxError),
) where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: Crane<A>,
    P: CanPort,
{
    while let Some((frame, e)) = port.lost(now_ms) {
        on_lost(&frame, &e);
        controller.transmit_failed(&frame);
    }
}
