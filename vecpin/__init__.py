from .machine import Machine, Axis, bundled_machines
