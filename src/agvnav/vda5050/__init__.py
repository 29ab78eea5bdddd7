"""VDA 5050 (issue 31): agvnav's simulated vehicle as a VDA 5050 vehicle a master control drives.

* :mod:`~agvnav.vda5050.schemas`: the official JSON schemas 2.0.0, 2.1.0, 3.0.0 (vendored, MIT) and
  the two checks of every message: schema validation and no key the schema does not define;
* :mod:`~agvnav.vda5050.messages`: pydantic models that read orders and instant actions and build
  state, visualization, connection and factsheet for each version;
* :mod:`~agvnav.vda5050.vehicle`: the order/state machine (acceptance, update stitching,
  rejections, node/edge/action states, blocking types, predefined actions) driving a simulated
  agvnav vehicle on a scenario's route network, independent of the transport;
* :mod:`~agvnav.vda5050.bus`: topics, an in-process bus on the simulated clock with the same
  validation as the broker, and the MQTT transport (paho-mqtt, the ``vda5050`` extra).
"""
