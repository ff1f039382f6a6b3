"""Tables of reference/px4-sitl-measured.md read as data, for the tests that hold the simulated PX4
to them (the file is the recording's index, written for people: its tables are markdown)."""

from offboard_py.dialect import mavlink

# PX4's integration-test mission MC_mission_box, flown in the recordings ("AUTO modes"): command,
# latitude, longitude, altitude above home (m)
MISSION_BOX = (
    (mavlink.MAV_CMD_NAV_TAKEOFF, 47.39773941, 8.54559040, 5.0),
    (mavlink.MAV_CMD_NAV_WAYPOINT, 47.39787292, 8.54559326, 10.0),
    (mavlink.MAV_CMD_NAV_WAYPOINT, 47.39787292, 8.54534149, 10.0),
    (mavlink.MAV_CMD_NAV_WAYPOINT, 47.39773941, 8.54533672, 10.0),
    (mavlink.MAV_CMD_NAV_WAYPOINT, 47.39773941, 8.54559040, 10.0),
    (mavlink.MAV_CMD_NAV_LAND, 47.39773941, 8.54559135, 0.0),
)


def available_modes(measured_md):
    """[(mode_index, custom_mode, PX4 mode, standard_mode, properties, mode_name)] from the table of
    "Turn 3 recordings", section 3 (AVAILABLE_MODES) in the file `measured_md`; its 19..26 row expands
    to the eight external modes AUTO.EXTERNAL1..8."""
    with open(measured_md) as f:
        text = f.read()
    section = text[text.index('### 3. AVAILABLE_MODES'):text.index('### 4.')]
    rows = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip('|').split('|')]
        if len(cells) != 6 or not cells[1].startswith('0x'):
            continue
        standard, properties = int(cells[3].split()[0]), int(cells[4])
        name = '' if cells[5] == '(empty)' else cells[5]
        if '..' in cells[0]:
            first, last = (int(n) for n in cells[0].split('..'))
            start = int(cells[1].split('..')[0], 16)
            for n in range(last - first + 1):
                rows.append((first + n, start + (n << 24), 'AUTO.EXTERNAL%d' % (n + 1), standard, properties, name))
        else:
            rows.append((int(cells[0]), int(cells[1], 16), cells[2], standard, properties, name))
    return rows
