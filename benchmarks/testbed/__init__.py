"""testbed: a SUPERball tensegrity in Bullet (pybullet) that shares no code with tensegrid.

It stands in for a real robot: data made here carry the model error that data from another
engine, or from hardware, always carry. It imports nothing from physics/, belief/, embeddings/
or planners/ (tests/testbed checks it) and writes trajectories with xarray in the format of
docs/data-format.md, the θ and effects that made them in attributes an identifier never reads.

Modules: ``params`` (the 15 parameters, node and cable layout), ``effects`` (hidden effects),
``robot`` (the Bullet world, cables, actuators), ``controller`` (its own flop controller),
``record`` (a flop as a Dataset), ``datasets`` (named data sets), ``__main__`` (the command
``tensegrid-testbed``). Modelling choices are listed in docs/testbed.md.
"""
