"""USS drives on Modbus TCP, MQTT and OPC UA: the faces of the plant's data points.

- `pyuss.gateway.faces`: the registry of faces, one `FaceSpec` each (and the ``pyuss.faces``
  entry points of other packages): config, extras, run and ``uss gateway`` iterate it.
- `pyuss.gateway.config`: the configuration file (buses, drives, faces).
- `pyuss.gateway.options`: the options of pyuss's faces and the readers of their tables.
- `pyuss.gateway.run`: `Gateway`, the plant and its faces started and stopped together.
- `pyuss.gateway.registers` (pure) and `pyuss.gateway.modbus` (a server of its own): Modbus TCP.
- `pyuss.gateway.topics`, `pyuss.gateway.payloads` and `pyuss.gateway.homeassistant` (pure)
  and `pyuss.gateway.mqtt` (aiomqtt; with `mqtt_drive`, `mqtt_commands`, `mqtt_client`): MQTT
  (topics and commands, the messages published), Home Assistant discovery.
- `pyuss.gateway.uanodes` (pure) and `pyuss.gateway.opcua` (asyncua; with `opcua_nodes`,
  `opcua_sessions`): OPC UA.

Each face module imports its own library only; the libraries are extras
(``pip install 'pyuss[modbus]'``, ``[mqtt]``, ``[opcua]``, ``[all]``). See docs/gateway.md.
"""
