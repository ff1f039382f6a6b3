"""The simulated PX4: commander, multicopter model, parameters, missions and MAVLink telemetry.

Nothing here imports rospy or the bridge: it runs as a plain process.
"""
