"""The bridge's parameters: defaults as mavros's px4.launch, and every bad value named."""

import pytest

from offboard_py.bridge.config import ConfigError, read_config
from offboard_py.mavlink_link import UrlError, parse_udp_url


def config(**params):
    params = {k.replace('__', '/'): v for k, v in params.items()}
    return read_config(lambda name, default: params.get(name, default))


def test_defaults_are_px4_sitl():
    cfg = config()
    assert cfg['fcu'][:2] == (('127.0.0.1', 14540), ('localhost', 14557))
    assert cfg['target_system_id'] == 1 and cfg['conn/timeout'] == 10.0
    assert (cfg['target_component_id'], cfg['system_id'], cfg['component_id']) == (1, 1, 240)
    assert cfg['signing'] is None and cfg['signing/required'] is True


@pytest.mark.parametrize('given, used', [(None, 10.0), ([16.2, 16.0], 16.2), (16.2, 10.0), ([], 10.0)])
def test_min_voltage_is_read_as_mavros_reads_it(given, used):
    """mavros reads sys/min_voltage as a list (a battery each); px4_config.yaml's single 10.0 is not one,
    so mavros keeps its default, also 10 V."""
    assert config(**({} if given is None else {'sys__min_voltage': given}))['sys/min_voltage'] == used


def test_signing_key_file_is_read(tmp_path):
    key = tmp_path / 'key.bin'
    key.write_bytes(bytes(range(1, 33)))
    cfg = config(signing__key_file=str(key), signing__required=False)
    assert cfg['signing'] == (bytes(range(1, 33)), 0) and cfg['signing/required'] is False


@pytest.mark.parametrize('params, words', [
    ({'fcu_url': 'tcp://localhost:5760'}, '~fcu_url'),
    ({'fcu_url': ''}, '~fcu_url'),
    ({'target_system_id': 0}, '~target_system_id'),
    ({'target_system_id': 1.5}, '~target_system_id'),
    ({'conn__timeout': float('nan')}, '~conn/timeout'),
    ({'conn__timeout': -1.0}, '~conn/timeout'),
    ({'signing__key_file': '/nonexistent/key.bin'}, '~signing/key_file'),
    ({'signing__required': 'yes'}, '~signing/required'),
    ({'time__timesync_mode': 'ONBOARD'}, '~time/timesync_mode'),
    ({'conn__timesync_rate': -1.0}, '~conn/timesync_rate'),
    ({'time__convergence_window': 0}, '~time/convergence_window'),
    ({'time__timesync_alpha_final': 2.0}, '~time/timesync_alpha_final'),
    ({'sys__min_voltage': ['ten']}, '~sys/min_voltage'),
    ({'sys__disable_diag': 1}, '~sys/disable_diag'),
])
def test_bad_parameters_are_named(params, words):
    with pytest.raises(ConfigError) as err:
        config(**params)
    assert words in str(err.value)


@pytest.mark.parametrize('url, bind, remote, broadcast, permanent', [
    # mavconn's rules: bind 14555 and remote 14550 when the URL leaves them out
    ('udp://@127.0.0.1', ('127.0.0.1', 14555), ('127.0.0.1', 14550), False, False),
    ('udp://', ('127.0.0.1', 14555), None, False, False),
    ('udp://:14540@localhost:14557', ('127.0.0.1', 14540), ('localhost', 14557), False, False),
    ('udp://0.0.0.0:14556@10.0.0.2:14551', ('0.0.0.0', 14556), ('10.0.0.2', 14551), False, False),
    ('udp-b://@', ('127.0.0.1', 14555), ('255.255.255.255', 14550), True, False),
    ('udp-b://:14560@:14570', ('127.0.0.1', 14560), ('255.255.255.255', 14570), True, False),
    ('udp-pb://@', ('127.0.0.1', 14555), ('255.255.255.255', 14550), True, True),
])
def test_udp_urls_follow_mavconn(url, bind, remote, broadcast, permanent):
    parsed = parse_udp_url(url)
    assert (parsed.bind, parsed.remote, parsed.broadcast, parsed.permanent) == (bind, remote, broadcast, permanent)


@pytest.mark.parametrize('url, words', [
    ('tcp://localhost:5760', "scheme 'tcp'"),
    ('udp-b://@10.0.0.1:14550', 'broadcast address'),
    ('udp://:0@', 'bind port 0'),
    ('udp://:99999@', 'bad bind address'),
    ('14550', 'cannot read URL'),
])
def test_bad_urls_are_named(url, words):
    with pytest.raises(UrlError) as err:
        parse_udp_url(url)
    assert words in str(err.value) and url in str(err.value)


def test_gcs_url_uses_mavconns_ports_not_the_ground_stations():
    """gcs_url:=udp://@127.0.0.1 talks to a ground station on 14550 from 14555, as mavros;
    the bridge must not bind 14550 itself (that is where QGroundControl listens)."""
    cfg = config(gcs_url='udp://@127.0.0.1')
    assert cfg['gcs'].bind == ('127.0.0.1', 14555) and cfg['gcs'].remote == ('127.0.0.1', 14550)
    assert config()['gcs'] is None
