"""A plant over the broker: the buses and drives that ``uss gateway`` processes publish on one
MQTT broker, read and commanded through their topics (`pyuss.gateway.topics`), never through
a master of its own.

`pyuss.plant.remote.RemotePlant` is one MQTT client that knows every gateway by its retained
gateway message (``uss/BUS/gateway``, `pyuss.gateway.announce`), every drive's state and
availability, and that sends commands as requests with a unique id and a reply topic of its
own, waiting for the one reply that answers each. `pyuss.plant.remote.RemoteParams` offers a
drive's parameter jobs over that request and reply, so that backups, comparisons and restores
(`pyuss.commission`) run unchanged over the broker. ``uss web --mqtt`` shows it
(`pyuss.web.plant`).
"""
