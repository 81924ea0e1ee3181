"""Speaking BehaviorTree.CPP's tooling formats: Groot2's live monitor, FileLogger2 logs (.btlog), node UIDs."""
