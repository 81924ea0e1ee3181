"""The test suite, one folder per floor of the code (core, behaviours, perception, sim, trees, app, groot, viz,
ros, sweep, cli), plus missions (closed-loop runs) and project (the repo itself: import contracts, wheel, docs,
bench). A package, so every test module has a full name (``tests.ros.test_node``) and helpers are imported as
``tests.helpers.…`` with no sys.path tricks."""
