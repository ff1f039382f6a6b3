"""PX4 SITL's UDP ports and system id of instance N: the one formula the simulator, the launch
files and the tests share (real PX4 SITL numbers its instances the same way, so either FCU can
stand at instance N).

  system id     N + 1
  FCU port      14580 + N   the FCU's onboard (offboard API) link binds it
  bridge port   14540 + N   mavros / the bridge binds it (fcu_url); the FCU sends there;
                            instance 10 excepted: 14620 (below)
  GCS port      18570 + N   the FCU's ground-station link binds it, and sends to 14550

14540 + 10 is 14550, the ground station's port: every instance's GCS link sends there (PX4's
GCS_REMOTE_PORT, for every instance), and QGroundControl binds it. A bridge of instance 10 bound
there takes in the GCS streams of the whole fleet (32 vehicles: about 11 800 datagrams a second,
15 % of a core for that one bridge; 2026-11-26) and keeps a ground station out. Its bridge binds
14620 instead, the first port past the FCU ports of instances 0-39, and the simulated PX4 of
instance 10 sends there. Real PX4 SITL sends the onboard link of every instance above 9 to 14549
(px4-rc.mavlink) until something speaks to it, then to that sender; the bridge, as mavros, sends
its HEARTBEAT from the start, so a real PX4 learns the bridge's port whichever it is.

roslaunch cannot import Python, so launch/sim_vehicle.launch spells the fcu_url formula once in
$(eval ...); test/unit/test_sitl_ports.py holds that spelling, and every .test file's, to this one.
"""

FCU_PORT_BASE = 14580
BRIDGE_PORT_BASE = 14540
GCS_PORT_BASE = 18570
GCS_REMOTE_PORT = 14550  # QGroundControl's, for every instance
BRIDGE_PORT_NOT_GCS = 14620  # instance 10's bridge port, where the formula would give GCS_REMOTE_PORT


def system_id(instance):
    return instance + 1


def fcu_port(instance):
    return FCU_PORT_BASE + instance


def bridge_port(instance):
    port = BRIDGE_PORT_BASE + instance
    return BRIDGE_PORT_NOT_GCS if port == GCS_REMOTE_PORT else port


def gcs_port(instance):
    return GCS_PORT_BASE + instance


def fcu_url(instance, host='localhost'):
    """mavros's fcu_url for instance N: bind the bridge port, send to the FCU port."""
    return 'udp://:%d@%s:%d' % (bridge_port(instance), host, fcu_port(instance))
