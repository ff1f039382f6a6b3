"""PX4 SITL's UDP ports and system id of instance N: the one formula the simulator, the launch
files and the tests share (real PX4 SITL numbers its instances the same way, so either FCU can
stand at instance N).

  system id     N + 1
  FCU port      14580 + N   the FCU's onboard (offboard API) link binds it
  bridge port   14540 + N   mavros / the bridge binds it (fcu_url); the FCU sends there
  GCS port      18570 + N   the FCU's ground-station link binds it, and sends to 14550

roslaunch cannot import Python, so launch/sim_vehicle.launch spells the fcu_url formula once in
$(eval ...); test/unit/test_sitl_ports.py holds that spelling, and every .test file's, to this one.
"""

FCU_PORT_BASE = 14580
BRIDGE_PORT_BASE = 14540
GCS_PORT_BASE = 18570
GCS_REMOTE_PORT = 14550  # QGroundControl's, for every instance


def system_id(instance):
    return instance + 1


def fcu_port(instance):
    return FCU_PORT_BASE + instance


def bridge_port(instance):
    return BRIDGE_PORT_BASE + instance


def gcs_port(instance):
    return GCS_PORT_BASE + instance


def fcu_url(instance, host='localhost'):
    """mavros's fcu_url for instance N: bind the bridge port, send to the FCU port."""
    return 'udp://:%d@%s:%d' % (bridge_port(instance), host, fcu_port(instance))
