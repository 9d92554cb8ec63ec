"""Vehicle: parameters, pure dynamics models, actuators and integrators."""
