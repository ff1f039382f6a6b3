"""The simulated PX4's MAVLink side, shaped as PX4's src/modules/mavlink so the two can be read side by side:

- receiver: a message becomes a vehicle command, a setpoint or a request, after PX4's checks (mavlink_receiver.cpp);
  vehicle_commands: the commands it passes on, read as PX4's commander reads them (Commander::handle_command);
- parameters: the parameter manager (mavlink_parameters.cpp);
- mission_manager: the mission transfer protocol (mavlink_mission.cpp);
- command_sender: the vehicle's own commands and the delayed ACKs (mavlink_command_sender.cpp);
- streams: each link's streams, rates and schedule (mavlink_main.cpp, mavlink_stream.cpp);
- messages, sensor_messages, system_messages: what the streams send, built from the flight's Status (streams/*.hpp);
- link_stats: LINK_NODE_STATUS's counters; statustext: the STATUSTEXT queue (mavlink_log, streams/STATUSTEXT.hpp);
- timesync: the TIMESYNC answer (mavlink_timesync.cpp);
- log_handler: the log protocol, listing and sending the logger's ULog files (mavlink_log_handler.cpp).

sim.autopilot wires them to the links and runs the cycle; the flight stack itself is sim.flight's.
"""
