"""tx200-twin."""
