//! What the EMCY producer announces for a fault (CiA 301 §7.2.7; docs/COMMANDS.md,
//! "EMCY"): the fault's error code and register from its facts ([`Fault::facts`]), and in
//! the manufacturer bytes the fault code, the drive's node and a detail — for a
//! commissioning failure the object, with the SDO abort code in a second EMCY. The queue
//! that sends them in order is [`crate::canopen::emcy::Producer`].

use crate::canopen::emcy::{ABORT_CODE_FOLLOWS, COMMISSIONING_ABORT};
use crate::canopen::emcy::{REGISTER_GENERIC, REGISTER_MANUFACTURER};
use crate::canopen::{self};
use crate::fault::Fault;
use crate::frame::CanFrame;

/// The EMCYs of node `node` announcing `fault`, whose drive (if any) is node
/// `drive_node`: the fault's, and for a commissioning failure EMCY 0xFF12 with the SDO
/// abort code, which does not fit beside the drive and the object.
pub(crate) fn announcement(node: u8, fault: Fault, drive_node: u8) -> (CanFrame, Option<CanFrame>) {
    let facts = fault.facts();
    let (info, abort) = match fault {
        // The object in the same layout: the sub-index as the detail, the index in the
        // last two bytes; the abort code follows in EMCY 0xFF12 (and 0x2002:4).
        Fault::Commissioning(_, error) => {
            let object = error.object();
            let [i0, i1] = object.index.to_le_bytes();
            let [a0, a1, a2, a3] = error.abort_code().to_le_bytes();
            let abort = canopen::emcy(
                node,
                COMMISSIONING_ABORT,
                REGISTER_GENERIC | REGISTER_MANUFACTURER,
                [ABORT_CODE_FOLLOWS, a0, a1, a2, a3],
            );
            ([facts.code, drive_node, object.sub, i0, i1], Some(abort))
        }
        _ => ([facts.code, drive_node, fault.detail(), 0, 0], None),
    };
    let emcy = canopen::emcy(
        node,
        facts.emcy_code,
        REGISTER_GENERIC | facts.register,
        info,
    );
    (emcy, abort)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canopen::emcy::{HEARTBEAT, REGISTER_COMMUNICATION};
    use crate::canopen::sdo::{Object, SdoError};
    use crate::commissioning::CommissioningError;
    use crate::drive::Drive;

    #[test]
    fn a_fault_is_one_emcy_with_its_code_register_node_and_detail() {
        let (emcy, abort) = announcement(1, Fault::HeartbeatLost(Drive::Winch), 3);
        assert_eq!(emcy.id(), 0x081);
        let facts = Fault::HeartbeatLost(Drive::Winch).facts();
        assert_eq!(facts.emcy_code, HEARTBEAT);
        let [c0, c1] = HEARTBEAT.to_le_bytes();
        assert_eq!(
            emcy.data(),
            &[
                c0,
                c1,
                REGISTER_GENERIC | REGISTER_COMMUNICATION,
                facts.code,
                3,
                0,
                0,
                0
            ]
        );
        assert_eq!(abort, None);
    }

    #[test]
    fn a_commissioning_failure_names_the_object_and_its_abort_code_follows() {
        let object = Object::new(0x6083, 0);
        let error = CommissioningError::Sdo(SdoError::Aborted {
            object,
            code: 0x0609_0030,
        });
        let fault = Fault::Commissioning(Drive::Trolley, error);
        let (emcy, abort) = announcement(1, fault, 2);
        let [c0, c1] = fault.facts().emcy_code.to_le_bytes();
        assert_eq!(
            emcy.data(),
            &[
                c0,
                c1,
                REGISTER_GENERIC | fault.facts().register,
                fault.code(),
                2,
                0,
                0x83,
                0x60
            ]
        );
        let [a0, a1] = COMMISSIONING_ABORT.to_le_bytes();
        let register = REGISTER_GENERIC | REGISTER_MANUFACTURER;
        assert_eq!(abort.map(|f| f.id()), Some(0x081));
        assert_eq!(
            abort.as_ref().map(CanFrame::data),
            Some(&[a0, a1, register, ABORT_CODE_FOLLOWS, 0x30, 0x00, 0x09, 0x06][..])
        );
    }
}
