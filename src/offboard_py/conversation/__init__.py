"""The conversation on the FCU link: what the ROS side and the FCU say to each other, and when.

One flight's recording (a pcap, or a decoded JSONL as in reference/conversations/) is read
into messages (reading), cut into the flight's phases (phases), summed up per direction and
phase: rates, commands and their answers, parameter and mission transactions, mode and arming
changes, TIMESYNC pairs, sequence gaps (analysis), and two summaries are compared figure by
figure (compare) and shown as a table and a PNG (report); a takeoff of our own stack is flown and
its link recorded by record_flight, the one module here that needs rospy.
"""
