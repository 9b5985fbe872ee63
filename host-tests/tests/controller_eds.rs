//! `can/crane-controller.eds` — what a PLC's configuration tool imports — against the
//! controller's object dictionary, declared once in `controller/src/canopen/od.rs`
//! (`od::CONTROLLER`) and served over SDO by `controller/src/node.rs`, and against the
//! DBC: the EDS and the table hold the same objects with the same data type, access and
//! name; the server answers exactly the table's objects, each with its data type's size
//! and, read at its defaults, the EDS's default value; the PDO mappings are the DBC's
//! frames. (python-canopen's parser reads the same file in the interop test.)

use std::collections::BTreeMap;

use controller::canopen::od::{self, Entry};
use controller::canopen::sdo::{abort, Object, ObjectDictionary};
use controller::canopen::NmtState;
use controller::commands::{Answer, Status, COMMAND_ID, MOVE3D_ID, STATUS_ID};
use controller::node::{Dictionary, Node, Role, Snapshot, StagedRequest};
use controller::operator::OPERATOR_ID;
use host_tests::dbc::Dbc;

const EDS: &str = include_str!("../../can/crane-controller.eds");

/// Sections of an INI file: name → key → value.
fn sections(text: &str) -> BTreeMap<String, BTreeMap<String, String>> {
    let mut out: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    let mut current = String::new();
    for line in text.lines().map(str::trim) {
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            current = name.to_string();
            out.entry(current.clone()).or_default();
        } else if let Some((k, v)) = line.split_once('=') {
            out.entry(current.clone())
                .or_default()
                .insert(k.trim().to_string(), v.trim().to_string());
        }
    }
    out
}

fn number(v: &str) -> u64 {
    match v.strip_prefix("0x").or_else(|| v.strip_prefix("0X")) {
        Some(hex) => u64::from_str_radix(hex, 16).unwrap(),
        None => v.parse().unwrap(),
    }
}

/// Every variable of the EDS: object, data type size (bytes), access, default value.
fn variables() -> Vec<(Object, usize, String, u64)> {
    let s = sections(EDS);
    let mut out = Vec::new();
    for (name, keys) in &s {
        if keys.get("ObjectType").map(String::as_str) != Some("0x7") {
            continue;
        }
        let (index, sub) = match name.split_once("sub") {
            Some((i, sub)) => (i, u8::from_str_radix(sub, 16).unwrap()),
            None => (name.as_str(), 0),
        };
        let size = match keys["DataType"].as_str() {
            "0x0005" => 1,
            // UNSIGNED16 and INTEGER16.
            "0x0006" | "0x0003" => 2,
            // UNSIGNED32 and INTEGER32.
            "0x0007" | "0x0004" => 4,
            other => panic!("{name}: data type {other} not used here"),
        };
        out.push((
            Object::new(u16::from_str_radix(index, 16).unwrap(), sub),
            size,
            keys["AccessType"].clone(),
            number(&keys["DefaultValue"]),
        ));
    }
    out
}

/// Every variable of the EDS as the table spells it: object, data type code, access,
/// name.
fn described() -> BTreeMap<Object, (u16, String, String)> {
    let mut out = BTreeMap::new();
    for (name, keys) in sections(EDS) {
        if keys.get("ObjectType").map(String::as_str) != Some("0x7") {
            continue;
        }
        let (index, sub) = match name.split_once("sub") {
            Some((i, sub)) => (i.to_string(), u8::from_str_radix(sub, 16).unwrap()),
            None => (name.clone(), 0),
        };
        let object = Object::new(u16::from_str_radix(&index, 16).unwrap(), sub);
        let data_type = u16::try_from(number(&keys["DataType"])).unwrap();
        out.insert(
            object,
            (
                data_type,
                keys["AccessType"].clone(),
                keys["ParameterName"].clone(),
            ),
        );
    }
    out
}

/// The table of the code and the EDS hold the same objects, each with the same data
/// type, access and name.
#[test]
fn the_eds_is_the_dictionary_table() {
    let eds = described();
    let table: BTreeMap<Object, (u16, String, String)> = od::CONTROLLER
        .iter()
        .map(|e: &Entry| {
            (
                e.object,
                (
                    e.data_type.code(),
                    e.access.eds().to_string(),
                    e.name.to_string(),
                ),
            )
        })
        .collect();
    assert_eq!(table.len(), od::CONTROLLER.len(), "each object once");
    for (object, facts) in &table {
        assert_eq!(eds.get(object), Some(facts), "{object:?} in the EDS");
    }
    for object in eds.keys() {
        assert!(
            table.contains_key(object),
            "{object:?} of the EDS not in the table"
        );
    }
}

/// The server answers each object of the table with its data type's size, refuses to
/// read a write-only one and to write a read-only one, and answers no other object.
#[test]
fn the_server_answers_exactly_the_table() {
    let mut n = node();
    let mut od = Dictionary {
        node: &mut n,
        snapshot: snapshot(),
    };
    for entry in &od::CONTROLLER {
        let read = od.read(entry.object);
        if entry.access.readable() {
            let value = read.unwrap_or_else(|code| panic!("{entry:?}: abort {code:#010x}"));
            assert_eq!(value.len(), usize::from(entry.size()), "{entry:?}");
        } else {
            assert_eq!(read, Err(abort::WRITE_ONLY), "{entry:?}");
        }
        if !entry.access.writable() {
            assert_eq!(
                od.write(entry.object, &[0; 4][..usize::from(entry.size())]),
                Err(abort::READ_ONLY),
                "{entry:?}"
            );
        }
    }
    for index in 0x1000..=0x2FFF {
        for sub in 0..=16 {
            let object = Object::new(index, sub);
            let known = od::CONTROLLER.iter().any(|e| e.object == object);
            let read = od.read(object);
            if !known {
                let expected = if od::CONTROLLER.iter().any(|e| e.object.index == index) {
                    abort::NO_SUB
                } else {
                    abort::NO_OBJECT
                };
                assert_eq!(read, Err(expected), "{object:?}");
                assert_eq!(od.write(object, &[0]), Err(expected), "{object:?}");
            }
        }
    }
}

fn node() -> Node {
    Node {
        id: 0x10,
        role: Role::Manager,
        state: NmtState::Operational,
        heartbeat_ms: 100,
        supervisor: 0,
        cycle_us: 10_000,
        request: StagedRequest::default(),
        operator: Default::default(),
        drives_consumer_ms: 300,
        listed: [1, 2, 0, 0],
    }
}

fn snapshot() -> Snapshot {
    Snapshot {
        status: Status {
            last_id: 0,
            answer: Answer::None,
            reason: None,
            overload: 0,
            mode: 0,
            fault: 0,
            ignored: 0,
            deadline_misses: 0,
            tx_failures: 0,
        },
        error_register: 0,
        commissioning_failure: (0, 0, 0, 0, 0),
        commissioned: 0,
        rope: (0, 0, 0, 0, u32::MAX, 0),
    }
}

#[test]
fn every_eds_object_answers_with_its_size_and_default() {
    let mut n = node();
    let od = Dictionary {
        node: &mut n,
        snapshot: snapshot(),
    };
    let vars = variables();
    assert!(vars.len() > 40, "{} variables", vars.len());
    for (object, size, access, default) in vars {
        let got = od.read(object);
        if access == "wo" {
            assert_eq!(got, Err(abort::WRITE_ONLY), "{object:?}");
            continue;
        }
        let value = got.unwrap_or_else(|code| panic!("{object:?}: abort {code:#010x}"));
        assert_eq!(value.len(), size, "{object:?}: size");
        let mut word = [0u8; 8];
        word[..size].copy_from_slice(&value);
        // The dictionary is read at its defaults: a fresh controller, no fault, no request.
        assert_eq!(u64::from_le_bytes(word), default, "{object:?}: value");
    }
}

#[test]
fn rw_objects_take_writes_and_ro_ones_refuse_them() {
    let mut n = node();
    for (object, size, access, default) in variables() {
        let mut od = Dictionary {
            node: &mut n,
            snapshot: snapshot(),
        };
        let bytes = &default.to_le_bytes()[..size];
        let got = od.write(object, bytes);
        match access.as_str() {
            "rw" => assert_eq!(got, Ok(()), "{object:?}"),
            "ro" | "const" => assert_eq!(got, Err(abort::READ_ONLY), "{object:?}"),
            // Writable: the request's fields. Command 0 is no command: refused as a
            // command frame with it is.
            "wo" if object == Object::new(0x2000, 2) => {
                assert_eq!(got, Err(abort::INVALID_VALUE), "{object:?}")
            }
            "wo" => assert_eq!(got, Ok(()), "{object:?}"),
            other => panic!("{object:?}: access type {other}"),
        }
    }
}

#[test]
fn the_pdo_descriptions_are_the_dbc_frames() {
    let s = sections(EDS);
    let dbc = Dbc::crane().unwrap();
    for (comm, map, id) in [
        ("1400", "1600", COMMAND_ID),
        ("1401", "1601", MOVE3D_ID),
        ("1402", "1602", OPERATOR_ID),
        ("1800", "1A00", STATUS_ID),
    ] {
        assert_eq!(
            number(&s[&format!("{comm}sub1")]["DefaultValue"]),
            u64::from(id)
        );
        let count = number(&s[&format!("{map}sub0")]["DefaultValue"]);
        let lengths: Vec<u64> = (1..=count)
            .map(|k| number(&s[&format!("{map}sub{k:X}")]["DefaultValue"]) & 0xFF)
            .collect();
        assert_eq!(Some(lengths), dbc.signal_sizes(id), "{map} against the DBC");
    }
    // A configuration tool sizes its PDO tables from DeviceInfo's counts (CiA 306).
    for (key, first) in [("NrOfRXPDO", 0x1400), ("NrOfTXPDO", 0x1800)] {
        let described = (first..first + 0x200)
            .take_while(|i| s.contains_key(&format!("{i:X}")))
            .count() as u64;
        assert_eq!(number(&s["DeviceInfo"][key]), described, "{key}");
    }
}
