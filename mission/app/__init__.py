"""The application: the one loop (runner), a simulated run start to finish, its metrics, report and observers."""
