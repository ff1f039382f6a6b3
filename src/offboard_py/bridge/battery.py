"""mavros sys_status's battery topic: ~battery (sensor_msgs/BatteryState).

From BATTERY_STATUS of battery 0 when the FCU sends it (PX4 does, at 0.5 Hz): voltage the sum
of the cells, each cell in cell_voltage, current (A, positive charging, so PX4's draw is
negative), percentage 0..1; temperature 0, which mavros 1.21 leaves as it is (BATTERY_STATUS's is
not read). Until then, from SYS_STATUS's battery fields (5 Hz), as mavros does. Unknown values are NaN.
"""

import math

from sensor_msgs.msg import BatteryState

from offboard_py.dialect import mavlink

UINT16_UNKNOWN = 0xFFFF
TECHNOLOGY = {mavlink.MAV_BATTERY_TYPE_LIPO: BatteryState.POWER_SUPPLY_TECHNOLOGY_LIPO,
              mavlink.MAV_BATTERY_TYPE_LIFE: BatteryState.POWER_SUPPLY_TECHNOLOGY_LIFE,
              mavlink.MAV_BATTERY_TYPE_LION: BatteryState.POWER_SUPPLY_TECHNOLOGY_LION,
              mavlink.MAV_BATTERY_TYPE_NIMH: BatteryState.POWER_SUPPLY_TECHNOLOGY_NIMH}


def _battery(stamp, voltage, current_ca, remaining_pct):
    msg = BatteryState()
    msg.header.stamp = stamp
    msg.voltage = voltage
    msg.current = -current_ca / 100.0 if current_ca != -1 else math.nan
    msg.charge = msg.capacity = msg.design_capacity = math.nan
    msg.percentage = remaining_pct / 100.0 if remaining_pct != -1 else math.nan
    msg.temperature = 0.0  # mavros 1.21 fills in no temperature
    msg.power_supply_status = BatteryState.POWER_SUPPLY_STATUS_DISCHARGING
    msg.power_supply_health = BatteryState.POWER_SUPPLY_HEALTH_UNKNOWN
    msg.power_supply_technology = BatteryState.POWER_SUPPLY_TECHNOLOGY_UNKNOWN
    msg.present = True
    return msg


class Battery:
    def __init__(self, bridge):
        self.bridge = bridge
        self.has_battery_status = False
        self.last = None  # (voltage V, current A, remaining 0..1) of the latest message
        self.cells = []
        self.min_voltage = bridge.cfg['sys/min_voltage']
        if not bridge.cfg['sys/disable_diag']:
            bridge.diagnostic('Battery', self._status)
        self.pub = bridge.publisher('~battery', BatteryState)
        bridge.on('SYS_STATUS', self._on_sys_status)
        bridge.on('BATTERY_STATUS', self._on_battery_status)

    def _status(self):
        """mavros's BatteryStatusDiag: 'No data' before any (voltage -1), 'Low voltage' under
        sys/min_voltage, the cells when there are several."""
        voltage, current, remaining = self.last if self.last is not None else (-1.0, 0.0, 0.0)
        values = [('Voltage', '%.2f' % voltage), ('Current', '%.1f' % current), ('Remaining', '%.1f' % (remaining * 100))]
        if len(self.cells) > 1:
            values += [('Cell %d' % i, '%.2f' % cell) for i, cell in enumerate(self.cells, 1)]
        if voltage < 0.0:
            return 2, 'No data', values
        return (1, 'Low voltage', values) if voltage < self.min_voltage else (0, 'Normal', values)

    def _on_sys_status(self, status):
        if self.has_battery_status:
            return
        voltage = status.voltage_battery / 1000.0 if status.voltage_battery != UINT16_UNKNOWN else math.nan
        msg = _battery(self.bridge.now(), voltage, status.current_battery, status.battery_remaining)
        self.last = (msg.voltage, msg.current, msg.percentage)
        if self.pub.get_num_connections():
            self.pub.publish(msg)

    def _on_battery_status(self, bs):
        if bs.id != 0:
            return
        self.has_battery_status = True
        cells = [v / 1000.0 for v in bs.voltages if v != UINT16_UNKNOWN]
        msg = _battery(self.bridge.now(), sum(cells) if cells else math.nan, bs.current_battery, bs.battery_remaining)
        msg.cell_voltage = self.cells = cells
        msg.power_supply_technology = TECHNOLOGY.get(bs.type, BatteryState.POWER_SUPPLY_TECHNOLOGY_UNKNOWN)
        msg.location = 'id%d' % bs.id
        self.last = (msg.voltage, msg.current, msg.percentage)
        if self.pub.get_num_connections():
            self.pub.publish(msg)
