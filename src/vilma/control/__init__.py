"""The car's autonomous functions: speed controllers, path controllers and the self-driver."""
