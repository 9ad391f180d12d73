"""The bus proxy as a component: the first child of every project's tree."""
