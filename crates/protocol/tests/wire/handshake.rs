//! The handshake check both sides use.

use protocol::*;

#[test]
fn equal_versions_pass() {
    assert_eq!(check_hello(PROTOCOL_VERSION, SCHEMA_ID), Ok(()));
    match RequestBody::hello() {
        RequestBody::Hello {
            protocol_version,
            schema_id,
            takeover: false,
        } => assert_eq!(check_hello(protocol_version, schema_id), Ok(())),
        other => panic!("hello() built {other:?}"),
    }
}

#[test]
fn a_different_schema_is_refused_naming_both() {
    let e = check_hello(PROTOCOL_VERSION, SCHEMA_ID ^ 1).unwrap_err();
    assert_eq!(
        e,
        VersionMismatch {
            local_protocol_version: PROTOCOL_VERSION,
            local_schema_id: SCHEMA_ID,
            peer_protocol_version: PROTOCOL_VERSION,
            peer_schema_id: SCHEMA_ID ^ 1,
        }
    );
    assert!(e.schema_differs());
    assert!(!e.protocol_differs());
}

#[test]
fn a_different_protocol_version_is_refused() {
    let e = check_hello(PROTOCOL_VERSION + 1, SCHEMA_ID).unwrap_err();
    assert!(e.protocol_differs());
    assert!(!e.schema_differs());
    assert_eq!(e.peer_protocol_version, PROTOCOL_VERSION + 1);
}

#[test]
fn the_host_checks_device_info() {
    let mut info = DeviceInfo {
        protocol_version: PROTOCOL_VERSION,
        schema_id: SCHEMA_ID,
        firmware_version: [0, 1, 0],
        board: Board::Simulator,
        trunk: TrunkConfig {
            bottom: ModuleConfig {
                n: 6,
                beta_deg: 35.0,
                edge_mm: 25.0,
                layers: 3,
            },
            top: ModuleConfig {
                n: 6,
                beta_deg: 31.72,
                edge_mm: 25.0,
                layers: 3,
            },
            pressure_limit_kpa: 40.0,
        },
        session: 0x1234_5678,
        reset_cause: ResetCause::PowerOn,
        signing: false,
    };
    assert_eq!(info.check(), Ok(()));
    info.schema_id = 7;
    assert_eq!(info.check().unwrap_err().peer_schema_id, 7);
}
