"""The simulated PX4's battery, as PX4 SITL has it: its battery_simulator module and the battery library
behind every PX4 battery (src/modules/simulation/battery_simulator/BatterySimulator.cpp,
src/lib/battery/battery.cpp, PX4 main 02e73e3b6f).

- BatterySimulator: while armed the charge falls by 1/SIM_BAT_DRAIN a second, down to SIM_BAT_MIN_PCT;
  disarmed it is full again at once. The pack's voltage is the charge mapped onto BAT1_V_EMPTY ..
  BAT1_V_CHARGED per cell, times BAT1_N_CELLS; no current sensor (-1 A). MAV_CMD_INJECT_FAILURE
  unit FAILURE_UNIT_SYSTEM_BATTERY, type OFF ("battery empty") pins the voltage to BAT1_V_EMPTY a cell
  until type OK; instance 0 only (any other: UNSUPPORTED); other failure types are not its own.
- Battery (the library): the cell voltage through a first-order filter of 1 s time constant sampled at
  100 Hz; with BAT1_CAPACITY -1 (PX4 SITL) the state of charge is that filtered voltage mapped onto
  V_EMPTY .. V_CHARGED. Its warning (NONE, LOW, CRITICAL, EMERGENCY below BAT_LOW_THR, BAT_CRIT_THR,
  BAT_EMERGEN_THR) is only judged once the battery has been connected 2 s.

So a battery switched off in flight shows its warnings one after the other as the filtered voltage
decays towards empty: from 89 % charge, LOW after 1.8 s, CRITICAL after 2.5 s, EMERGENCY after 2.9 s
(reference/px4-sitl-measured.md, "Turn 4 recordings", item 6; reference/px4-sitl-battery-off.tsv).
Pure: time is passed in.
"""

import math

from offboard_py.dialect import FAILURE_TYPE_OFF, FAILURE_TYPE_OK

SAMPLE_INTERVAL_S = 0.01      # BATTERY_SIMLATOR_SAMPLE_FREQUENCY_HZ 100
FILTER_TIME_CONSTANT_S = 1.0  # battery.cpp: _cell_voltage_filter_v.setParameters(dt, 1.f)
INITIALISE_AFTER_S = 2.0      # battery.cpp: warnings judged 2 s after the battery is connected
# battery_status_s::WARNING_*
WARNING_NONE, WARNING_LOW, WARNING_CRITICAL, WARNING_EMERGENCY, WARNING_FAILED = 0, 1, 2, 3, 4
BATTERY_UNIT_INSTANCE = 0     # the only instance BatterySimulator takes


def warning_for(state_of_charge, params):
    """Battery::determineWarning: the warning for a state of charge 0..1."""
    if state_of_charge < params['BAT_EMERGEN_THR']:
        return WARNING_EMERGENCY
    if state_of_charge < params['BAT_CRIT_THR']:
        return WARNING_CRITICAL
    if state_of_charge < params['BAT_LOW_THR']:
        return WARNING_LOW
    return WARNING_NONE


class BatterySimulator:
    """PX4 SITL's simulated battery and what PX4's battery library makes of it. `step(now_s, armed)`
    runs its 100 Hz samples up to now; read voltage_v, remaining (0..1) and warning."""

    def __init__(self, params, now_s):
        self.params = params
        self.percentage = 1.0        # BatterySimulator::_battery_percentage
        self.force_empty = False     # FAILURE_TYPE_OFF injected
        self.connected_s = now_s
        self.last_sample_s = now_s
        self.voltage_v = self._pack_voltage()
        self.filtered_cell_v = self.voltage_v / self.cells
        self.warning = WARNING_NONE

    @property
    def cells(self):
        return max(1, int(self.params['BAT1_N_CELLS']))

    def inject(self, failure_type, instance):
        """MAV_CMD_INJECT_FAILURE for FAILURE_UNIT_SYSTEM_BATTERY: True (ACCEPTED) or False (UNSUPPORTED)
        for OFF and OK, None for a type BatterySimulator leaves to others (PX4 then sends no answer)."""
        if failure_type not in (FAILURE_TYPE_OFF, FAILURE_TYPE_OK):
            return None
        if instance != BATTERY_UNIT_INSTANCE:
            return False
        self.force_empty = failure_type == FAILURE_TYPE_OFF
        return True

    def _pack_voltage(self):
        p = self.params
        v_empty, v_full = p['BAT1_V_EMPTY'], p['BAT1_V_CHARGED']
        cell = v_empty if self.force_empty else v_empty + (v_full - v_empty) * self.percentage
        return cell * self.cells

    @property
    def remaining(self):
        """State of charge 0..1 from the filtered cell voltage (BAT1_CAPACITY -1: voltage based)."""
        p = self.params
        v_empty, v_full = p['BAT1_V_EMPTY'], p['BAT1_V_CHARGED']
        if v_full <= v_empty:
            return 0.0
        return min(1.0, max(0.0, (self.filtered_cell_v - v_empty) / (v_full - v_empty)))

    def step(self, now_s, armed):
        n = int(math.floor((now_s - self.last_sample_s) / SAMPLE_INTERVAL_S + 1e-9))
        if n <= 0:
            return
        p = self.params
        alpha = SAMPLE_INTERVAL_S / (FILTER_TIME_CONSTANT_S + SAMPLE_INTERVAL_S)
        drain_s = p['SIM_BAT_DRAIN']
        floor = p['SIM_BAT_MIN_PCT'] / 100.0
        for _ in range(n):
            self.last_sample_s += SAMPLE_INTERVAL_S
            if armed and drain_s > 0:
                self.percentage -= SAMPLE_INTERVAL_S / drain_s
            elif not armed:
                self.percentage = 1.0
            self.percentage = max(self.percentage, floor)
            self.voltage_v = self._pack_voltage()
            cell_v = self.voltage_v / self.cells
            if self.last_sample_s < self.connected_s + INITIALISE_AFTER_S:
                self.filtered_cell_v = cell_v  # resetInternalResistanceEstimation until initialised
                continue
            self.filtered_cell_v += alpha * (cell_v - self.filtered_cell_v)
            self.warning = warning_for(self.remaining, p)
