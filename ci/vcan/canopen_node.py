"""A CANopen node from an independent stack (the `canopen` package from PyPI), answering
SDO uploads and downloads (expedited and segmented) on vcan0, so that `hob can` is checked
against someone else's reading of CiA 301. Runs until killed."""
import sys
import time

import canopen

NODE = int(sys.argv[1]) if len(sys.argv) > 1 else 10
IFACE = sys.argv[2] if len(sys.argv) > 2 else "vcan0"

od = canopen.ObjectDictionary()
for index, name, dtype, value, access in [
    (0x1000, "Device type", canopen.objectdictionary.UNSIGNED32, 0x000F0191, "ro"),
    (0x1008, "Manufacturer device name", canopen.objectdictionary.VISIBLE_STRING, "independent python-canopen node", "ro"),
    (0x2001, "Set point", canopen.objectdictionary.UNSIGNED32, 0, "rw"),
    (0x2002, "Label", canopen.objectdictionary.VISIBLE_STRING, "", "rw"),
]:
    var = canopen.objectdictionary.ODVariable(name, index, 0)
    var.data_type = dtype
    var.access_type = access
    var.default = value
    od.add_object(var)

network = canopen.Network()
network.connect(interface="socketcan", channel=IFACE)
node = canopen.LocalNode(NODE, od)
network.add_node(node)
print(f"python canopen LocalNode {NODE} on {IFACE}", flush=True)
while True:
    time.sleep(1)
