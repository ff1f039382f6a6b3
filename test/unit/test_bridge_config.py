"""The bridge's parameters: defaults as mavros's px4.launch, and every bad value named."""

import pytest

from offboard_py.bridge.config import ConfigError, read_config


def config(**params):
    params = {k.replace('__', '/'): v for k, v in params.items()}
    return read_config(lambda name, default: params.get(name, default))


def test_defaults_are_px4_sitl():
    cfg = config()
    assert cfg['fcu'] == (('127.0.0.1', 14540), ('localhost', 14557))
    assert cfg['target_system_id'] == 1 and cfg['conn/timeout'] == 10.0
    assert (cfg['target_component_id'], cfg['system_id'], cfg['component_id']) == (1, 1, 240)
    assert cfg['signing'] is None and cfg['signing/required'] is True


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
])
def test_bad_parameters_are_named(params, words):
    with pytest.raises(ConfigError) as err:
        config(**params)
    assert words in str(err.value)
