"""The balancing stage: order-by-order design of balancer elements, the lever
balancer's weight, and verification by the exact model."""
