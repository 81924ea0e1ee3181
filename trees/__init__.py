"""Tree files (BehaviorTree.CPP v4 XML) and the loader that builds py_trees from them."""
