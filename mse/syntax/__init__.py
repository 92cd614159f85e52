"""XML and constraint-expression text to a positioned AST."""
